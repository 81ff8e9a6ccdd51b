"""Each robot's MJX-JAX physics: which step, friction cone and solver iterations hold it standing
and let it walk without blowing up.

    MENAGERIE_ROOT=/work/shared/menagerie python experiments/robots/physics/measure.py \
        --robots quad12,menagerie:unitree_go1 --out experiments/robots/physics/results.json

Per robot × setting (physics_dt:cone:solver_iterations:ls_iterations[:kp:kd]), one jitted,
vmapped rollout of `--envs` robots (reset joint noise 0.02 rad) for `--seconds` s on each terrain
(one compile per robot × setting × terrain; `action_filter_tau=0` so that a constant action acts
from the first step):

- flat: half the robots hold the home pose (rhythm amplitudes 0), half walk the fixed trot (the
  zero action);
- slope5: a quarter hold at x = 0 (flat ground before the 5° ramp), a quarter on the 5° uphill
  (x = 3), a quarter on the 5° downhill (x = 9.5), a quarter trot from x = 0.

Reported: the largest |base height − standing height| / standing height while holding (over the
first 5 s, and over the whole rollout), robots with a NaN, falls (the env's fall check), the trot's
mean forward speed (robots that did not fall), compile and run wall time. The hold error is also
taken against a reference height (`reference_height`: the same robot settled in C MuJoCo with
converged physics), from 0.5 s on (after the drop from the spawn clearance): Menagerie's soft feet
(solimp 0.015 1 0.02x) sink about 14 mm and finite gains sag, so no physics setting reaches the
kinematic standing height. A setting passes when no robot has a NaN or falls, and the hold stays
within 5 % of the reference height for 5 s on both terrains.

At every passing setting a grid of constant gaits (A_h × A_k × T, the fixed trot's phases) walks on
flat ground (same compiled rollout); each gait's speed over 5 s and whether it fell is recorded.
"""

import argparse
import dataclasses
import itertools
import json
import math
import pathlib
import sys
import time

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

import quadcos
from quadcos.equations import oscillator
from quadcos import robot as robot_lib
from quadcos.env.layout import Layout
from quadcos.robot import presets

DEFAULT_ROBOTS = (
    "quad12",
    "menagerie:unitree_go1",
    "menagerie:unitree_go2",
    "menagerie:anybotics_anymal_c",
)
# Cheapest first: fewer substeps, pyramidal before elliptic, fewer iterations.
DEFAULT_SETTINGS = tuple(
    f"{dt}:{cone}:{iters}:{ls}"
    for dt in (0.005, 0.0025)
    for cone in ("pyramidal", "elliptic")
    for iters, ls in ((1, 4), (2, 4), (4, 8))
)
HOLD_TOLERANCE = 0.05  # of the standing height
JUDGE_SECONDS = 5.0  # s: hold error and gait speed are judged over the first 5 s
SETTLE_SECONDS = 0.5  # s: the drop from the spawn clearance, before the hold is judged
# The reference a hold is judged against: the same robot (collision profile, gains) in C MuJoCo
# with the MJCF's elliptic cones, a 2 ms step and 100 Newton iterations, holding for 3 s.
REFERENCE = {"physics_dt": 0.002, "cone": "elliptic", "iterations": 100, "seconds": 3.0}
SLOPE_HOLD_X = (0.0, 3.0, 9.5)  # m on slope5: flat run-up, 5° uphill, 5° downhill
GAIT_GRID = {  # constant gaits, the fixed trot's phases
    "amplitude_hip": (0.1, 0.2, 0.3, 0.45),
    "amplitude_knee": (0.25, 0.45),
    "period": (0.3, 0.45, 0.6, 1.0),
}


@dataclasses.dataclass(frozen=True)
class Setting:
    physics_dt: float
    cone: str
    solver_iterations: int
    ls_iterations: int
    kp: float | None = None
    kd: float | None = None

    @classmethod
    def parse(cls, text: str) -> "Setting":
        parts = text.split(":")
        if len(parts) not in (4, 6):
            raise ValueError(f"setting {text!r}: expected dt:cone:iters:ls[:kp:kd]")
        gains = (float(parts[4]), float(parts[5])) if len(parts) == 6 else (None, None)
        return cls(float(parts[0]), parts[1], int(parts[2]), int(parts[3]), *gains)

    @property
    def label(self) -> str:
        text = f"{self.physics_dt * 1000:g}ms {self.cone} {self.solver_iterations}/{self.ls_iterations}"
        if self.kp is not None:
            text += f" kp{self.kp:g} kd{self.kd:g}"
        return text


def use_setting(spec: str, setting: Setting) -> None:
    """Puts `setting`'s cone (and PD gains) into the robot's preset, in this process only."""
    name = robot_lib.sources.resolve(spec).name
    preset = presets.preset_for(name)
    changes = {"cone": setting.cone}
    if setting.kp is not None:
        changes |= {"kp": setting.kp, "kd": setting.kd}
    presets.PRESETS[name] = dataclasses.replace(preset, **changes)
    robot_lib.load.cache_clear()


def reference_height(spec: str, setting: Setting) -> float:
    """The base height (m) the robot settles at holding its home pose with converged physics
    (REFERENCE): what soft feet and finite gains allow, below the kinematic standing height."""
    ref = Setting(
        REFERENCE["physics_dt"],
        REFERENCE["cone"],
        REFERENCE["iterations"],
        8,
        setting.kp,
        setting.kd,
    )
    use_setting(spec, ref)
    env = quadcos.make_env(
        "flat",
        robot=spec,
        impl="jax",
        physics_dt=ref.physics_dt,
        solver_iterations=ref.solver_iterations,
        ls_iterations=ref.ls_iterations,
    )
    model = env.mj_model
    layout = Layout.of(env.robot.description, model, xp=np)
    data = mujoco.MjData(model)
    data.qpos[layout.joint_qpos] = layout.home
    data.qpos[layout.position[2]] = layout.standing_height + 0.002
    for _ in range(round(REFERENCE["seconds"] / ref.physics_dt)):
        data.ctrl[:] = layout.controls(layout.home, data)
        mujoco.mj_step(model, data)
    return float(data.qpos[layout.position[2]])


def make_rollout(env, steps: int):
    """A jitted rollout: (states, actions (B, A)) → per-step base clearance along the ground
    normal, x, finite, done — each (steps, B)."""
    layout, terrain = env.layout, env.terrain

    def record(state):
        data = state.pipeline_state
        position = data.qpos[layout.position]
        ground = terrain.height_at(position[0], position[1])
        clearance = (position[2] - ground) * jnp.cos(terrain.slope_at(position[0], position[1]))
        finite = jnp.isfinite(data.qpos).all() & jnp.isfinite(data.qvel).all()
        return clearance, position[0], finite, state.done > 0

    step = jax.vmap(env.step)

    @jax.jit
    def rollout(states, actions):
        def body(states, _):
            states = step(states, actions)
            return states, jax.vmap(record)(states)

        _, out = jax.lax.scan(body, states, None, length=steps)
        return out

    return rollout


def run_batch(env, rollout, xs, actions, seed):
    keys = jax.random.split(jax.random.PRNGKey(seed), len(xs))
    zeros = jnp.zeros(len(xs))
    states = jax.vmap(env.reset_at)(keys, jnp.asarray(xs, jnp.float32), zeros)
    started = time.perf_counter()
    out = jax.block_until_ready(rollout(states, jnp.asarray(actions)))
    elapsed = time.perf_counter() - started
    clearance, x, finite, done = (np.asarray(a) for a in out)
    x0 = np.asarray(states.pipeline_state.qpos[:, env.layout.position[0]])
    return clearance, x, finite, done, x0, elapsed


def _finite_or_none(value) -> float | None:
    """A JSON number, or None (null) for a NaN or infinite one (a robot that blew up)."""
    value = float(value)
    return value if math.isfinite(value) else None


def summarise(env, clearance, x, finite, done, x0, hold, judge_steps, reference):
    """Per-group numbers of one batch: hold (mask) robots' height error (against the standing
    height and the `reference` settled height), trot robots' speed."""
    standing = env.robot.description.standing_height
    settle = round(SETTLE_SECONDS / env.dt)
    nan = ~finite.all(axis=0)
    fell = done.any(axis=0)
    with np.errstate(invalid="ignore"):
        error = np.abs(clearance / standing - 1.0)
        ref_error = np.abs(clearance / reference - 1.0)
    error = np.where(np.isfinite(error), error, np.inf)
    ref_error = np.where(np.isfinite(ref_error), ref_error, np.inf)

    def group(mask):
        return {
            "robots": int(mask.sum()),
            "nan": int(nan[mask].sum()),
            "falls": int(fell[mask].sum()),
        }

    result = {}
    if hold.any():
        result["hold"] = group(hold) | {
            "max_height_error_5s": _finite_or_none(error[:judge_steps, hold].max()),
            "max_height_error_all": _finite_or_none(error[:, hold].max()),
            "final_height_fraction": _finite_or_none(np.mean(clearance[-1, hold] / standing)),
            "max_reference_error_5s": _finite_or_none(ref_error[settle:judge_steps, hold].max()),
            "max_reference_error_all": _finite_or_none(ref_error[settle:, hold].max()),
        }
    walk = ~hold
    if walk.any():
        ok = walk & ~fell & ~nan
        t5 = judge_steps * env.dt
        speed5 = (x[judge_steps - 1] - x0) / t5
        speed_all = (x[-1] - x0) / (len(x) * env.dt)
        result["trot"] = group(walk) | {
            "speed_5s": float(speed5[ok].mean()) if ok.any() else None,
            "speed_all": float(speed_all[ok].mean()) if ok.any() else None,
        }
    return result


def measure(spec: str, setting: Setting, args) -> dict:
    reference = reference_height(spec, setting)
    use_setting(spec, setting)
    overrides = {
        "robot": spec,
        "impl": "jax",
        "physics_dt": setting.physics_dt,
        "solver_iterations": setting.solver_iterations,
        "ls_iterations": setting.ls_iterations,
        "action_filter_tau": 0.0,
    }
    steps = round(args.seconds / 0.05)
    judge_steps = round(JUDGE_SECONDS / 0.05)
    n = args.envs
    record = {"setting": setting.label, **dataclasses.asdict(setting), "terrains": {}}
    record["reference_height"] = reference
    passed = True
    for terrain in ("flat", "slope5"):
        env = quadcos.make_env(terrain, **overrides)
        assert env.config.physics_dt == setting.physics_dt
        assert env.mj_model.opt.iterations == setting.solver_iterations
        hold_action = env.action_for(
            oscillator.RhythmParameters(0.0, 0.0, 0.6, math.pi / 2, -math.pi / 2)
        )
        trot_action = jnp.zeros(env.action_size)
        if terrain == "flat":
            hold = np.arange(n) < n // 2
            xs = np.zeros(n)
        else:
            quarter = n // 4
            hold = np.arange(n) < 3 * quarter
            xs = np.zeros(n)
            for i, x_hold in enumerate(SLOPE_HOLD_X):
                xs[i * quarter : (i + 1) * quarter] = x_hold
        actions = np.where(hold[:, None], np.asarray(hold_action), np.asarray(trot_action))
        rollout = make_rollout(env, steps)
        keys = jax.random.split(jax.random.PRNGKey(0), n)
        started = time.perf_counter()
        states = jax.vmap(env.reset_at)(keys, jnp.asarray(xs, jnp.float32), jnp.zeros(n))
        rollout.lower(states, jnp.asarray(actions)).compile()
        compile_s = time.perf_counter() - started
        clearance, x, finite, done, x0, run_s = run_batch(env, rollout, xs, actions, args.seed)
        result = summarise(env, clearance, x, finite, done, x0, hold, judge_steps, reference)
        if terrain == "slope5":  # the hold error of each spawn
            per_spawn = {}
            for i, x_hold in enumerate(SLOPE_HOLD_X):
                mask = np.zeros(n, bool)
                mask[i * (n // 4) : (i + 1) * (n // 4)] = True
                per_spawn[f"x={x_hold:g}"] = summarise(
                    env, clearance, x, finite, done, x0, mask, judge_steps, reference
                )["hold"]
            result["hold_by_spawn"] = per_spawn
        result |= {
            "compile_s": round(compile_s, 1),
            "run_s": round(run_s, 2),
            "env_steps_per_s": round(n * steps / run_s, 1),
        }
        record["terrains"][terrain] = result
        hold_r, trot_r = result["hold"], result["trot"]
        ok = (
            hold_r["nan"] == 0
            and hold_r["falls"] == 0
            and hold_r["max_reference_error_5s"] is not None
            and hold_r["max_reference_error_5s"] <= HOLD_TOLERANCE
            and trot_r["nan"] == 0
            and trot_r["falls"] == 0
        )
        passed &= ok
        print(
            f"  {terrain:6s} hold err {hold_r['max_height_error_5s']} vs ref {hold_r['max_reference_error_5s']}"
            f" (all {hold_r['max_height_error_all']},"
            f" final {hold_r['final_height_fraction']}) nan {hold_r['nan']}+{trot_r['nan']}"
            f" falls {hold_r['falls']}+{trot_r['falls']} trot {trot_r['speed_5s']}"
            f" compile {compile_s:.0f}s run {run_s:.1f}s",
            flush=True,
        )
        if terrain == "flat":
            flat_env, flat_rollout = env, rollout
    record["passed"] = bool(passed)
    if passed and not args.no_gaits:
        record["gaits"] = gait_grid(flat_env, flat_rollout, n, judge_steps, args.seed)
    return record


def gait_grid(env, rollout, n, judge_steps, seed) -> list[dict]:
    """Constant gaits on flat ground: speed over the first 5 s and whether the robot fell."""
    grid = list(itertools.product(*GAIT_GRID.values()))
    rows = []
    for start in range(0, len(grid), n):
        chunk = grid[start : start + n]
        params = [
            oscillator.RhythmParameters(ak, ah, t, math.pi / 2, -math.pi / 2) for ah, ak, t in chunk
        ]
        actions = np.stack([np.asarray(env.action_for(p)) for p in params])
        actions = np.concatenate([actions, np.zeros((n - len(chunk), actions.shape[1]))])
        _, x, finite, done, x0, _ = run_batch(env, rollout, np.zeros(n), actions, seed)
        for i, (ah, ak, t) in enumerate(chunk):
            fell = bool(done[:judge_steps, i].any() or not finite[:judge_steps, i].all())
            rows.append(
                {
                    "amplitude_hip": ah,
                    "amplitude_knee": ak,
                    "period": t,
                    "fell_5s": fell,
                    "speed_5s": float((x[judge_steps - 1, i] - x0[i]) / (judge_steps * env.dt)),
                }
            )
    best = max((r for r in rows if not r["fell_5s"]), key=lambda r: r["speed_5s"], default=None)
    print(
        f"  gaits: {sum(not r['fell_5s'] for r in rows)}/{len(rows)} upright; best {best}",
        flush=True,
    )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--robots", default=",".join(DEFAULT_ROBOTS), help="comma-separated robot specs"
    )
    parser.add_argument(
        "--settings",
        default=",".join(DEFAULT_SETTINGS),
        help="comma-separated dt:cone:iters:ls[:kp:kd], tried in order",
    )
    parser.add_argument(
        "--first-pass", action="store_true", help="stop a robot at its first passing setting"
    )
    parser.add_argument("--envs", type=int, default=32, help="robots per rollout (a multiple of 4)")
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-gaits", action="store_true", help="skip the constant-gait grid")
    parser.add_argument(
        "--out", type=pathlib.Path, required=True, help="JSON file (merged into if present)"
    )
    args = parser.parse_args()
    if args.envs % 4:
        parser.error("--envs must be a multiple of 4")
    settings = [Setting.parse(s) for s in args.settings.split(",") if s]
    results = json.loads(args.out.read_text()) if args.out.exists() else {}
    for spec in args.robots.split(","):
        entry = results.setdefault(spec, {})
        for setting in settings:
            print(f"{spec} {setting.label}", flush=True)
            record = measure(spec, setting, args)
            record |= {
                "envs": args.envs,
                "seconds": args.seconds,
                "jax_backend": jax.default_backend(),
            }
            entry[setting.label] = record
            args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text(json.dumps(results, indent=1) + "\n")
            if args.first_pass and record["passed"]:
                break
    return 0


if __name__ == "__main__":
    sys.exit(main())
