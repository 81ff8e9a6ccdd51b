"""The reward of paper §3.3, Eqs. 8–13, and the r_xy ablation of Fig. 9.

Pure JAX, for one robot (batch with jax.vmap). Axes: the paper's forward axis is world Y and its
sideways axis world X; quadcos walks along MuJoCo's +x. So the paper's r_y (Eq. 10, forward
progress) is written here with x, and its r_x (Eq. 11, sideways drift) with y.

Eq. 13: r = α r_p + β (r_s + r_y + r_x + r_o), α = 1 and β = 0 when the robot falls, else α = 0
and β = 1. `reward_terms` returns every term already multiplied by α or β, so the terms sum to r
and can be logged one by one as reward/<name>.

Velocity commands (issue 58, beyond the paper; `quadcos.env.commands`) generalise two terms: the
step's displacement is measured along the commanded heading ψ* (forward) and across it (lateral)
instead of along x and y; the forward term pays progress up to the commanded distance v*·dt and
takes back what exceeds it (`forward_tracking`); the yaw term penalises the yaw relative to ψ*
(`orientation`), or where a yaw-rate error ω − ω* is given, that error (rad/s). With ψ* = 0 (ω* = 0
throughout) and no v*, every term is Eqs. 8–13 exactly.

One more term, beyond the paper and 0 by default (`RewardWeights.action_rate`): the change of the
controller's command (the filtered action) over the step, squared, charged while walking.
"""

from typing import NamedTuple

import jax.numpy as jnp

VARIANTS = ("full", "xy")
# The keys of `reward_terms`, in Eq. 13's order and then the action-rate term beyond it; the env logs
# each as reward/<name>.
TERM_NAMES = ("fall", "survival", "forward", "lateral", "orientation", "action_rate")


class RewardWeights(NamedTuple):
    """Paper defaults (§3.3): r_p = −100, r_s = 10, w1..w5 = 150, 100, 30, 40, 30."""

    fall_penalty: float = -100.0
    survival: float = 10.0
    forward: float = 150.0  # w1
    lateral: float = 100.0  # w2
    pitch: float = 30.0  # w3
    yaw: float = 40.0  # w4
    roll: float = 30.0  # w5
    action_rate: float = 0.0  # not §3.3's: per unit of the command's squared change in a step


def fall_penalty(weights: RewardWeights) -> jnp.ndarray:
    """Eq. 8: r_p = −100, given when the robot falls (the episode then ends)."""
    return jnp.asarray(weights.fall_penalty)


def survival(weights: RewardWeights, moving: jnp.ndarray = True) -> jnp.ndarray:
    """Eq. 9: r_s = 10 "for every step of movement" without falling. `moving` says whether this
    step counts as movement; the env decides (every step alive, or only steps moving forward)."""
    return jnp.where(moving, weights.survival, 0.0)


def forward_progress(
    x_now: jnp.ndarray,
    x_last: jnp.ndarray,
    weights: RewardWeights,
    max_progress: float = jnp.inf,
) -> jnp.ndarray:
    """Eq. 10 (the paper's r_y): w1 (x_now − x_last), metres along the walking direction; with a
    finite `max_progress` (m, an extension: the env's `forward_speed_cap` × dt) progress beyond it
    earns nothing more."""
    return weights.forward * jnp.minimum(x_now - x_last, max_progress)


def forward_tracking(
    progress: jnp.ndarray, commanded_progress: jnp.ndarray, weights: RewardWeights
) -> jnp.ndarray:
    """Eq. 10 generalised to track a commanded speed v*: w1 (c − |d − c|) for progress d (m)
    along the commanded heading and commanded progress c = v*·dt (m): w1·d up to c (Eq. 10's
    reward for progress), falling again beyond it, so that the best step covers exactly c."""
    return weights.forward * (commanded_progress - jnp.abs(progress - commanded_progress))


def along_heading(
    dx: jnp.ndarray, dy: jnp.ndarray, heading: jnp.ndarray
) -> tuple[jnp.ndarray, jnp.ndarray]:
    """A world displacement (dx, dy) (m) as (forward, lateral) along and across heading ψ (rad,
    from +x towards +y); at ψ = 0 exactly (dx, dy)."""
    cos, sin = jnp.cos(heading), jnp.sin(heading)
    return dx * cos + dy * sin, dy * cos - dx * sin


def lateral_drift(y_now: jnp.ndarray, y_last: jnp.ndarray, weights: RewardWeights) -> jnp.ndarray:
    """Eq. 11 (the paper's r_x): −w2 |y_now − y_last|, metres sideways."""
    return -weights.lateral * jnp.abs(y_now - y_last)


def orientation(
    pitch: jnp.ndarray,
    yaw: jnp.ndarray,
    roll: jnp.ndarray,
    slope: jnp.ndarray,
    weights: RewardWeights,
) -> jnp.ndarray:
    """Eq. 12: r_o = −w3 |pitch − θ| − w4 |yaw| − w5 |roll|; θ is the Eq. 5 slope estimate (rad).
    With velocity commands `yaw` is the yaw relative to the commanded heading ψ* (wrapped to
    [−π, π]; `yaw_error`), or the yaw-rate error ω − ω* (rad/s)."""
    return (
        -weights.pitch * jnp.abs(pitch - slope)
        - weights.yaw * jnp.abs(yaw)
        - weights.roll * jnp.abs(roll)
    )


def action_rate(change: jnp.ndarray, weights: RewardWeights) -> jnp.ndarray:
    """−w_a Σ_i Δc_i²: the controller's command (the filtered action, in the action's units)
    changed by `change` (..., A) over the step. Beyond the paper (w_a = 0 by default): a policy
    whose action chatters from one step to the next shakes the rhythm it sets."""
    return -weights.action_rate * jnp.sum(jnp.square(change), axis=-1)


def wrap_angle(angle: jnp.ndarray) -> jnp.ndarray:
    """`angle` (rad) in [−π, π]: unchanged, bit for bit, where it already is."""
    wrapped = jnp.mod(angle + jnp.pi, 2 * jnp.pi) - jnp.pi
    return jnp.where(jnp.abs(angle) > jnp.pi, wrapped, angle)


def yaw_error(yaw: jnp.ndarray, heading: jnp.ndarray) -> jnp.ndarray:
    """The yaw (rad) relative to the commanded heading ψ* (rad), in [−π, π]; at ψ* = 0 exactly
    `yaw` (a yaw in [−π, π])."""
    return wrap_angle(yaw - heading)


def reward_terms(
    *,
    x_now: jnp.ndarray,
    x_last: jnp.ndarray,
    y_now: jnp.ndarray,
    y_last: jnp.ndarray,
    pitch: jnp.ndarray,
    yaw: jnp.ndarray,
    roll: jnp.ndarray,
    slope: jnp.ndarray,
    fell: jnp.ndarray,
    moving: jnp.ndarray = True,
    weights: RewardWeights = RewardWeights(),
    variant: str = "full",
    max_progress: float = jnp.inf,
    heading: jnp.ndarray | None = None,
    commanded_progress: jnp.ndarray | None = None,
    yaw_rate_error: jnp.ndarray | None = None,
    tracked_progress: jnp.ndarray | None = None,
    action_change: jnp.ndarray | None = None,
) -> dict[str, jnp.ndarray]:
    """Eq. 13's terms, each weighted by α or β; their sum is the step reward. `moving`: whether
    this step earns Eq. 9's r_s (see `survival`); `max_progress`: see `forward_progress`.

    Velocity commands: `heading` ψ* (rad) turns the forward, lateral and yaw terms to the
    commanded heading; `commanded_progress` v*·dt (m), where given, makes the forward term
    `forward_tracking`; `yaw_rate_error` ω − ω* (rad/s), where given, replaces the yaw relative to
    ψ* in the yaw term; `tracked_progress` (m), where given with `commanded_progress`, is the
    progress the forward term tracks in place of the step's own (the speed low-passed over a
    stride or two, `env.commands.speed_tau`; `max_progress` caps it after the low-pass). Without
    them (as with ψ* = 0, bit for bit) the terms are Eqs. 8–13.
    `action_change` (..., A), the command's change over the step, where given, is charged by
    `action_rate` (the term is 0 without it).

    variant "full" is Eq. 13. variant "xy" is Fig. 9's r_xy: only r_y + r_x while walking (no r_s,
    no r_o); a fall still gives r_p and ends the episode, as in the full reward.

    Returns:
      {"fall", "survival", "forward", "lateral", "orientation", "action_rate"} -> (...,)
      arrays.
    """
    if variant not in VARIANTS:
        raise ValueError(f"unknown reward variant {variant!r}; known: {', '.join(VARIANTS)}")
    alpha = jnp.asarray(fell, jnp.float32)
    beta = 1.0 - alpha
    walking = beta if variant == "full" else jnp.zeros_like(beta)
    progress, sideways = x_now - x_last, y_now - y_last
    if heading is not None:
        progress, sideways = along_heading(progress, sideways, heading)
        yaw = yaw_error(yaw, heading)
    if yaw_rate_error is not None:
        yaw = yaw_rate_error
    if commanded_progress is None:
        forward = forward_progress(progress, 0.0, weights, max_progress)
    else:
        tracked = progress if tracked_progress is None else tracked_progress
        forward = forward_tracking(jnp.minimum(tracked, max_progress), commanded_progress, weights)
    return {
        "fall": alpha * fall_penalty(weights),
        "survival": walking * survival(weights, moving),
        "forward": beta * forward,
        "lateral": beta * lateral_drift(sideways, 0.0, weights),
        "orientation": walking * orientation(pitch, yaw, roll, slope, weights),
        "action_rate": (
            jnp.zeros_like(beta)
            if action_change is None
            else walking * action_rate(action_change, weights)
        ),
    }
