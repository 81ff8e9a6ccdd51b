"""Domain randomisation: each robot walks with physics of its own (issue 16).

A robot draws its `Physics` at every reset and keeps it for the episode, in the env state's
`info`; its step applies the draw to the shared MJX model with `model.replace` inside
`jax.vmap`, so the batch runs one compiled program whatever the draws (no recompilation, no
per-env model copies on the host). Both physics take it: MJX-JAX batches the replaced fields, and
MJX-Warp (mujoco-mjx 3.17) passes each of them per world to its kernels (geom_friction, body_mass,
body_ipos, actuator_gainprm / biasprm / forcerange, dof_damping; tests/test_randomization.py
checks Warp against JAX under the same draws). Off by default (`env.randomization.enabled`).

What is randomised, with default ranges after published locomotion work — legged_gym (Rudin et
al. 2022, "Learning to walk in minutes using massively parallel deep RL": friction U(0.5, 1.25),
±1 kg on the base, pushes every 15 s) and MuJoCo Playground's Go1 (`domain_randomize`: floor
friction U(0.4, 1.0), body masses ×U(0.9, 1.1), base mass ±1 kg, joint friction and armature
±5–10 %) — widened where the issue's robustness table probes further:

- sliding friction of every geom (MuJoCo takes the larger of the two geoms' at a contact);
- torso mass (×) and the torso's centre of mass (± metres on each axis);
- the position servos' gain kp (×; torque motors, whose PD the env closes, keep their gains) and
  the joints' damping (×);
- motor strength: the torque limit (×) of the servos and of the torque motors' PD;
- control latency: a new action reaches the command filter this many seconds late (whole physics
  steps; the previous action acts meanwhile); with `delay_drive` the command's drive as well;
- pushes: a force of `push_force_n` in a random horizontal direction on the torso for
  `push_duration_s`, starting on average every `push_interval_s`;
- observation noise: N(0, `obs_noise`²) on each value of the observation the policy sees (the
  phase and command too, where observed; 0, the default, adds none), as `quadcos.sim2sim
  --obs_noise` adds in C MuJoCo. Brax's auto-reset restarts an env from its first state, so its
  episodes begin with the same noisy first observation.

`conditions` replaces the ranges by named robustness conditions (`CONDITIONS`, one per robot,
its index in the env state's `info["condition"]`): the training evaluations of
`eval_conditions` measure a policy under each at once (quadcos.training.periodic_eval).

Every range is (low, high) in SI units; equal ends fix a value, which is how an evaluation applies
one perturbation (`quadcos.evaluate --env.randomization.enabled=True
--env.randomization.friction='(0.4, 0.4)'`).

A draw acts at its `level` (1, the default: fully): at level ℓ each drawn value is the nominal
robot's moved a share ℓ of the way towards the draw (friction from each geom's own, scales from 1,
CoM offset, latency and push force from 0). Training can ramp ℓ from 0 to 1 over each robot's
first `ramp_s` seconds (`quadcos.training.curriculum.RandomizationRamp`); evaluations draw at
level 1.
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp
import ml_collections
import numpy as np

RANGES = (
    "friction",
    "torso_mass_scale",
    "kp_scale",
    "damping_scale",
    "strength_scale",
    "latency_s",
)


def default_config() -> ml_collections.ConfigDict:
    config = ml_collections.ConfigDict()
    config.enabled = False
    config.friction = (0.4, 1.5)  # the MJCF's is 1.5 (ground and feet)
    config.torso_mass_scale = (0.85, 1.25)  # the MJCF's torso is 12 kg of the robot's 16 kg
    config.com_offset_m = 0.03  # ± on each axis of the torso's centre of mass
    config.kp_scale = (0.9, 1.1)
    config.damping_scale = (0.8, 1.2)
    config.strength_scale = (0.75, 1.1)
    config.latency_s = (0.0, 0.04)
    # With commands and the feed-forward: the drive's scales late by the latency as the action
    # is (the previous control step's meanwhile), its loops' feedback on yaw and speed with them;
    # False: the drive acts at once, and a gait (zero actions) is untouched by latency.
    config.delay_drive = False
    config.push_force_n = 50.0
    config.push_duration_s = 0.1
    config.push_interval_s = 5.0  # mean time between pushes; 0: no pushes
    config.obs_noise = 0.0  # std on each observation value the policy sees
    config.ramp_s = 0.0  # training only: level 0 → 1 over each robot's first ramp_s s; 0: none
    # The share of draws of each range at one of its ends (either, evenly) instead of inside it:
    # the extremes the robustness conditions test; 0: uniform (the draws as without it).
    config.range_ends = 0.0
    # Instead of the ranges: each robot takes one of these `CONDITIONS` (names joined by ";";
    # "robustness": the four of `ROBUSTNESS`), evenly at random, at level 1 ("": the ranges).
    # `eval_conditions`: those of the training-time evaluations (the trainer's evaluation env
    # takes them as its `conditions`), which then report each condition's falls and tracking
    # beside the pooled ones (and the kept policy must beat its gait in each: `best_policy`).
    config.conditions = ""
    config.eval_conditions = ""
    return config


# Env overrides (`make_env(**NOMINAL)`, `env_overrides=` of an evaluation) of randomised robots
# all drawn as the nominal one: every range at its nominal value (friction 1.5, the paper's MJCF's
# and the top of the default range), no pushes, no observation noise. With one range added, a
# single perturbation: experiments/robustness/measure.py's conditions.
NOMINAL = {
    "randomization.enabled": True,
    "randomization.friction": (1.5, 1.5),
    "randomization.torso_mass_scale": (1.0, 1.0),
    "randomization.com_offset_m": 0.0,
    "randomization.kp_scale": (1.0, 1.0),
    "randomization.damping_scale": (1.0, 1.0),
    "randomization.strength_scale": (1.0, 1.0),
    "randomization.latency_s": (0.0, 0.0),
    "randomization.push_interval_s": 0.0,
    "randomization.obs_noise": 0.0,
    "randomization.conditions": "",  # (a policy trained on conditions: the ranges above)
}


# The robustness conditions of experiments/robustness/measure.py: each is the nominal robot
# (NOMINAL) with one perturbation, as env overrides.
CONDITIONS = {
    "nominal": {},
    "friction 0.4": {"randomization.friction": (0.4, 0.4)},
    "friction 1.0": {"randomization.friction": (1.0, 1.0)},
    "friction 1.5": {"randomization.friction": (1.5, 1.5)},
    "torso mass +20 %": {"randomization.torso_mass_scale": (1.2, 1.2)},
    "motor strength -20 %": {"randomization.strength_scale": (0.8, 0.8)},
    "latency 40 ms": {"randomization.latency_s": (0.04, 0.04)},
    "observation noise 0.05": {"randomization.obs_noise": 0.05},
    # 50 N for 0.1 s, every 2 s on average (about ten pushes per 20-s episode).
    "pushes 50 N, 0.1 s": {
        "randomization.push_force_n": 50.0,
        "randomization.push_duration_s": 0.1,
        "randomization.push_interval_s": 2.0,
    },
}
# What the kept policy of a commanded run must beat its gait in (`eval_conditions` of the command
# preset): survival and tracking under each.
ROBUSTNESS = ("nominal", "latency 40 ms", "pushes 50 N, 0.1 s", "friction 0.4")
_PUSH = ("push_force_n", "push_duration_s", "push_interval_s")


def condition_names(spec: str) -> tuple[str, ...]:
    """The condition names of a `conditions` spec: names of `CONDITIONS` joined by ";", where
    "robustness" stands for `ROBUSTNESS` ("" → none)."""
    names = (name.strip() for name in spec.split(";")) if spec.strip() else ()
    return tuple(n for name in names for n in (ROBUSTNESS if name == "robustness" else (name,)))


def condition_values(name: str) -> dict[str, float]:
    """One condition's values: the low end of each of `RANGES` (its fixed value), the CoM offset,
    the push settings and the observation noise."""
    config = default_config()
    for key, value in {**NOMINAL, **CONDITIONS[name]}.items():
        config[key.removeprefix("randomization.")] = value
    values = {field: float(config[field][0]) for field in RANGES}
    return values | {field: float(config[field]) for field in ("com_offset_m", *_PUSH, "obs_noise")}


def condition_key(name: str) -> str:
    """A condition's name as a metric key part: "pushes 50 N, 0.1 s" → "pushes_50_n_0.1_s"."""
    return "_".join(name.lower().replace(",", " ").replace("%", "pct").split())


class Physics(NamedTuple):
    """One robot's draw (the nominal robot: friction of the MJCF, scales 1, no latency, no push)."""

    friction: jax.Array  # () sliding friction
    torso_mass_scale: jax.Array  # ()
    com_offset: jax.Array  # (3,) m
    kp_scale: jax.Array  # ()
    damping_scale: jax.Array  # ()
    strength_scale: jax.Array  # ()
    latency_steps: jax.Array  # () int32, physics steps
    push: jax.Array  # (3,) N on the torso now (zero between pushes), as drawn
    push_left_s: jax.Array  # () s
    level: jax.Array  # () in [0, 1]: the share of the way from the nominal robot to the draw


def validate(config: ml_collections.ConfigDict) -> None:
    """Raises ValueError naming the first value that cannot be drawn from."""
    for name in RANGES:
        low, high = (float(value) for value in config[name])
        if not (np.isfinite(low) and np.isfinite(high) and 0 <= low <= high):
            raise ValueError(
                f"randomization.{name} must be (low, high) with 0 <= low <= high; got {config[name]}"
            )
    names = ("com_offset_m", "push_force_n", "push_duration_s", "push_interval_s", "obs_noise")
    for name in (*names, "ramp_s"):
        if not 0 <= config[name] < np.inf:
            raise ValueError(f"randomization.{name} must be finite and >= 0; got {config[name]}")
    if not 0 <= config.range_ends <= 1:
        ends = config.range_ends
        raise ValueError(f"randomization.range_ends must be a share from 0 to 1; got {ends}")
    for field in ("conditions", "eval_conditions"):
        names = condition_names(config[field])
        unknown = [name for name in names if name not in CONDITIONS]
        if unknown:
            raise ValueError(
                f"randomization.{field}: unknown condition {unknown[0]!r}; give names joined by"
                f" ';' from {list(CONDITIONS)}"
            )
        if len(set(names)) < len(names):
            raise ValueError(f"randomization.{field}: a condition named twice in {names}")
    if config.conditions.strip() and not config.enabled:  # (eval_conditions: the trainer's)
        raise ValueError("randomization.conditions needs randomization.enabled")


def sample(rng: jax.Array, config: ml_collections.ConfigDict, physics_dt: float) -> Physics:
    """A fresh draw for one robot (no push under way): from the ranges, or one of `conditions`."""
    names = condition_names(config.conditions)
    if names:
        return _condition_draw(condition_index(rng, config), names, physics_dt)
    keys = jax.random.split(rng, len(RANGES) + 1)
    drawn = {name: _draw(key, *config[name], config.range_ends) for name, key in zip(RANGES, keys)}
    offset = config.com_offset_m
    return Physics(
        friction=drawn["friction"],
        torso_mass_scale=drawn["torso_mass_scale"],
        com_offset=jax.random.uniform(keys[-1], (3,), minval=-offset, maxval=offset),
        kp_scale=drawn["kp_scale"],
        damping_scale=drawn["damping_scale"],
        strength_scale=drawn["strength_scale"],
        latency_steps=jnp.round(drawn["latency_s"] / physics_dt).astype(jnp.int32),
        push=jnp.zeros(3),
        push_left_s=jnp.zeros(()),
        level=jnp.ones(()),
    )


def condition_index(rng: jax.Array, config: ml_collections.ConfigDict) -> jax.Array:
    """() int32: which of `conditions` the robot whose draw key is `rng` takes (its index; the
    env keeps it as `info["condition"]`), evenly at random: the one `sample` draws from it."""
    return jax.random.randint(rng, (), 0, len(condition_names(config.conditions)))


def _condition_draw(index: jax.Array, names: tuple[str, ...], physics_dt: float) -> Physics:
    """The robot of the condition `names[index]`."""
    table = _table(names)

    def value(field: str) -> jax.Array:
        return table[field][index]

    return Physics(
        friction=value("friction"),
        torso_mass_scale=value("torso_mass_scale"),
        com_offset=jnp.zeros(3),  # every condition's (NOMINAL's)
        kp_scale=value("kp_scale"),
        damping_scale=value("damping_scale"),
        strength_scale=value("strength_scale"),
        latency_steps=jnp.round(value("latency_s") / physics_dt).astype(jnp.int32),
        push=jnp.zeros(3),
        push_left_s=jnp.zeros(()),
        level=jnp.ones(()),
    )


def _table(names: tuple[str, ...]) -> dict[str, jax.Array]:
    """Each condition value of `names` as an array over the conditions."""
    rows = [condition_values(name) for name in names]
    return {field: jnp.array([row[field] for row in rows], jnp.float32) for field in rows[0]}


def _draw(key: jax.Array, low: float, high: float, ends: float) -> jax.Array:
    """U(low, high), or with probability `ends` one of the two ends (each half of that); the
    uniform draw is the same for any `ends`, which only replaces it."""
    value = jax.random.uniform(key, (), minval=low, maxval=high)
    if ends == 0:
        return value
    pick = jax.random.uniform(jax.random.fold_in(key, 1), ())
    return jnp.where(pick < ends / 2, low, jnp.where(pick < ends, high, value))


def scale(physics: Physics, name: str) -> jax.Array:
    """A drawn scale at the draw's level: 1 at level 0, as drawn at level 1."""
    return 1.0 + physics.level * (getattr(physics, name) - 1.0)


def apply(model, physics: Physics, torso_body: int):
    """The MJX model with one robot's draw at its level (under `jax.vmap`, a per-robot model)."""
    gain = model.actuator_gainprm[:, 0]
    servo = model.actuator_biasprm[:, 1] < 0  # a position servo's bias is −kp·q; a motor's 0
    kp = jnp.where(servo, gain * scale(physics, "kp_scale"), gain)
    bias = jnp.where(servo, -kp, model.actuator_biasprm[:, 1])
    friction = model.geom_friction[:, 0]
    return model.replace(
        geom_friction=model.geom_friction.at[:, 0].set(
            friction + physics.level * (physics.friction - friction)
        ),
        body_mass=model.body_mass.at[torso_body].multiply(scale(physics, "torso_mass_scale")),
        body_ipos=model.body_ipos.at[torso_body].add(physics.level * physics.com_offset),
        actuator_gainprm=model.actuator_gainprm.at[:, 0].set(kp),
        actuator_biasprm=model.actuator_biasprm.at[:, 1].set(bias),
        dof_damping=model.dof_damping * scale(physics, "damping_scale"),
        actuator_forcerange=model.actuator_forcerange * strength(physics),
    )


def strength(physics: Physics) -> jax.Array:
    """The torque motors' limit scale at the draw's level (the env clips their PD torques; a
    servo's limit is its `actuator_forcerange`, scaled by `apply`)."""
    return scale(physics, "strength_scale")


def latency_steps(physics: Physics) -> jax.Array:
    """The physics steps a new action waits, at the draw's level."""
    return jnp.round(physics.level * physics.latency_steps).astype(jnp.int32)


def push_force(physics: Physics) -> jax.Array:
    """(3,) N on the torso now, at the draw's level."""
    return physics.level * physics.push


def next_push(
    rng: jax.Array,
    physics: Physics,
    config: ml_collections.ConfigDict,
    dt: float,
    condition: jax.Array | None = None,
) -> Physics:
    """One control step of the push process: a push under way runs down; otherwise one starts
    with probability dt / push_interval_s, in a random horizontal direction (the settings of the
    robot's `condition`, its `condition_index`, where the env draws `conditions`)."""
    if not (_anywhere(config, "push_interval_s") and _anywhere(config, "push_force_n")):
        return physics
    force_n, duration_s, interval_s = _settings(config, condition, _PUSH)
    start_key, angle_key = jax.random.split(rng)
    left = jnp.maximum(physics.push_left_s - dt, 0.0)
    if condition is None:
        start = (left <= 0) & (jax.random.uniform(start_key) < dt / interval_s)
    else:  # a condition without pushes: interval 0
        rate = jnp.where(interval_s > 0, dt / jnp.maximum(interval_s, 1e-9), 0.0)
        start = (left <= 0) & (jax.random.uniform(start_key) < rate) & (force_n > 0)
    angle = jax.random.uniform(angle_key, maxval=2 * jnp.pi)
    force = force_n * jnp.array([jnp.cos(angle), jnp.sin(angle), 0.0])
    push = jnp.where(start, force, jnp.where(left > 0, physics.push, 0.0))
    return physics._replace(push=push, push_left_s=jnp.where(start, duration_s, left))


def _settings(
    config: ml_collections.ConfigDict, condition: jax.Array | None, fields: tuple[str, ...]
) -> tuple:
    """The config's values of `fields`, or (`condition` given: the env draws `conditions`) those
    of the robot's condition."""
    if condition is None:
        return tuple(config[field] for field in fields)
    table = _table(condition_names(config.conditions))
    return tuple(table[field][condition] for field in fields)


def _anywhere(config: ml_collections.ConfigDict, field: str) -> bool:
    """Whether `field` is > 0 for any robot of an env with this config."""
    names = condition_names(config.conditions)
    if names:
        return any(condition_values(name)[field] > 0 for name in names)
    return config[field] > 0


def has_obs_noise(config: ml_collections.ConfigDict) -> bool:
    """Whether any robot of an env with this config sees observation noise."""
    return _anywhere(config, "obs_noise")


def observed(
    rng: jax.Array,
    obs: jax.Array,
    config: ml_collections.ConfigDict,
    condition: jax.Array | None = None,
) -> jax.Array:
    """What the policy sees of `obs`: each value plus N(0, obs_noise²) (the noise of the robot's
    `condition` where the env draws `conditions`)."""
    (noise,) = _settings(config, condition, ("obs_noise",))
    return obs + noise * jax.random.normal(rng, obs.shape, obs.dtype)


def step_info(
    info: dict,
    just_reset: jax.Array,
    config: ml_collections.ConfigDict,
    physics_dt: float,
    dt: float,
) -> dict:
    """A randomised robot's env `info` for its next control step (of `dt` s): its physics drawn
    anew after Brax's auto-reset (which keeps the finished episode's `info`), kept after `reset`
    (which drew it, `fresh_draw`: an evaluation groups its robots by that draw's condition), then
    the push process advanced (`next_push`); the previous action zeroed after a reset. With
    `conditions` the robot's condition is drawn anew with its physics."""
    redraw = just_reset & ~info["fresh_draw"]
    rng, draw_key, push_key = jax.random.split(info["rng"], 3)
    fresh = sample(draw_key, config, physics_dt)
    fresh = fresh._replace(level=info["physics"].level)  # a level is the trainer's to set
    physics = jax.tree.map(lambda a, b: jnp.where(redraw, a, b), fresh, info["physics"])
    stepped = {**info, "rng": rng, "fresh_draw": jnp.zeros((), bool)}
    if condition_names(config.conditions):
        fresh_condition = condition_index(draw_key, config)
        stepped["condition"] = jnp.where(redraw, fresh_condition, info["condition"])
    stepped["physics"] = next_push(push_key, physics, config, dt, stepped.get("condition"))
    stepped["action"] = jnp.where(just_reset, 0.0, info["action"])  # acts during latency
    return stepped


def seen(obs: jax.Array, info: dict, config: ml_collections.ConfigDict) -> tuple[jax.Array, dict]:
    """(`obs` as a randomised robot's policy sees it, `info` with its rng advanced): `observed`
    where the config has observation noise, else `obs` and `info` as they are."""
    if not has_obs_noise(config):
        return obs, info
    rng, noise_key = jax.random.split(info["rng"])
    return observed(noise_key, obs, config, info.get("condition")), {**info, "rng": rng}
