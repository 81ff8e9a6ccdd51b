"""Command tracking as every evaluation measures it (issue 58's `speed_tracking_rms` and
`yaw_rate_tracking_rms`): a step's speed along the robot's heading and its yaw rate, each averaged
over windows of TRACKING_WINDOW_S, against the command (v*, ω*) the robot followed in the step;
the RMS over the closed windows of those averaged errors.

Pure functions of batched (n,) arrays, jit-able: `quadcos.evaluation`'s rollout and the trainer's
periodic evaluation (`quadcos.training.periodic_eval`) count with them.
"""

import flax.struct
import jax
import jax.numpy as jnp

from quadcos.equations import reward, slope
from quadcos.robot import constants

# s: command tracking is measured on the speed and yaw rate averaged over windows this long — a
# stride or more of the gaits the presets find (periods 0.15-0.4 s), so that the sway within a
# stride (the yaw rate of a trot swings by about ±0.5 rad/s) is not counted as tracking error.
TRACKING_WINDOW_S = 0.5


def window_steps(dt: float) -> int:
    """Control steps of `dt` s in a tracking window (at least 1)."""
    return max(1, round(TRACKING_WINDOW_S / dt))


@flax.struct.dataclass
class Windows:
    """Running tracking sums of n episodes, each (n,): the open window's sums of the speed and
    yaw-rate errors, Σ over the closed windows of the squared mean error in the window ((m/s)²,
    (rad/s)²), and the windows closed."""

    open_speed_error: jax.Array
    open_yaw_rate_error: jax.Array
    speed_sq_error: jax.Array
    yaw_rate_sq_error: jax.Array
    windows: jax.Array  # int32

    @classmethod
    def zeros(cls, n: int) -> "Windows":
        zero = jnp.zeros(n)
        return cls(zero, zero, zero, zero, jnp.zeros(n, jnp.int32))


def pose(qpos: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
    """x, y (m) and yaw (rad) of batched free-floating robots' positions (n, nq)."""
    yaw = slope.attitude(qpos[:, constants.QPOS_QUATERNION]).yaw
    return qpos[:, 0], qpos[:, 1], yaw


def velocity(
    before: tuple[jax.Array, ...], after: tuple[jax.Array, ...], dt: float
) -> tuple[jax.Array, jax.Array]:
    """A step's speed (m/s) along the heading at its end and its yaw rate (rad/s), from the
    `pose`s before and after it, `dt` s apart."""
    (x0, y0, yaw0), (x1, y1, yaw1) = before, after
    speed = ((x1 - x0) * jnp.cos(yaw1) + (y1 - y0) * jnp.sin(yaw1)) / dt
    return speed, reward.wrap_angle(yaw1 - yaw0) / dt


def advance(
    sums: Windows,
    speed: jax.Array,
    yaw_rate: jax.Array,
    command: jax.Array,
    counts: jax.Array,
    steps: jax.Array,
    window: int,
) -> Windows:
    """`sums` after one step of `speed`, `yaw_rate` ((n,) each) under `command` ((n, 2): v*, ω*)
    for the episodes that ran in it (`counts`); a window closes where an episode's step count
    after it (`steps`) is a multiple of `window`."""
    def add(total, error):
        return jnp.where(counts, total + error, total)

    speed_error = add(sums.open_speed_error, speed - command[:, 0])
    yaw_rate_error = add(sums.open_yaw_rate_error, yaw_rate - command[:, 1])
    closed = counts & (steps % window == 0)

    def close(total, errors):
        return jnp.where(closed, total + (errors / window) ** 2, total)

    return Windows(
        open_speed_error=jnp.where(closed, 0.0, speed_error),
        open_yaw_rate_error=jnp.where(closed, 0.0, yaw_rate_error),
        speed_sq_error=close(sums.speed_sq_error, speed_error),
        yaw_rate_sq_error=close(sums.yaw_rate_sq_error, yaw_rate_error),
        windows=sums.windows + closed.astype(jnp.int32),
    )


def pooled_rms(sums: Windows) -> tuple[jax.Array, jax.Array]:
    """The speed (m/s) and yaw-rate (rad/s) tracking RMS of all episodes' closed windows pooled,
    episodes with a non-finite sum left out; NaN without a closed window."""
    finite = jnp.isfinite(sums.speed_sq_error) & jnp.isfinite(sums.yaw_rate_sq_error)
    windows = jnp.sum(jnp.where(finite, sums.windows, 0))

    def rms(sum_of_squares):
        total = jnp.sum(jnp.where(finite, sum_of_squares, 0.0))
        return jnp.where(windows > 0, jnp.sqrt(total / jnp.maximum(windows, 1)), jnp.nan)

    return rms(sums.speed_sq_error), rms(sums.yaw_rate_sq_error)
