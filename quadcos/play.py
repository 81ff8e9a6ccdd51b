"""Watch a policy walk: `python -m quadcos.play --policy DIR|FILE|fixed:trot --terrain SPEC`.

MuJoCo's interactive viewer (`mujoco.viewer.launch_passive`) shows the robot on the terrain, driven
in real time through `quadcos.deploy.host_robot.HostRobot` (the env's controller path in C MuJoCo, the
policy's NumPy forward pass), the camera following the torso. `--policy` is read as everywhere (`quadcos.evaluation.PolicySpec`),
env options as `--env.KEY=VALUE`. The overlay reads the time, forward
speed, attitude, the slope estimate beside the ground truth and the five rhythm parameters.

Keys: space pauses and resumes; R or Backspace restarts (next reset noise seed); Tab and
Shift-Tab show MuJoCo's own panels. A policy trained with velocity commands is steered: it
follows its own commands (or `--commands=SPEC`) until an arrow key is pressed, then the command
given by hand until a restart: up / down change the forward speed v* by 0.1 m/s, left / right
the yaw rate ω* by 0.1 rad/s (left turns left), within the ranges the policy was trained with;
space stops it (v* = ω* = 0, v* at least the range's minimum); P pauses. A fallen robot waits
for a restart. Without a display the command says so in one line and exits with status 2: render a video instead with
`python -m quadcos.evaluate ... --video=walk.mp4`.
"""

import argparse
import math
import os
import sys
import time
from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from quadcos._util import cli
from quadcos.deploy import engines
from quadcos.deploy.host_robot import HostRobot, Pilot, StepResult
from quadcos.robot import constants

KEY_SPACE, KEY_R, KEY_P, KEY_BACKSPACE = 32, ord("R"), ord("P"), 259  # GLFW key codes
KEY_RIGHT, KEY_LEFT, KEY_DOWN, KEY_UP = 262, 263, 264, 265
COMMAND_STEP = 0.1  # m/s or rad/s per arrow key press
_STEERING = {  # key -> (Δv*, Δω*) in COMMAND_STEPs
    KEY_UP: (1, 0),
    KEY_DOWN: (-1, 0),
    KEY_LEFT: (0, 1),
    KEY_RIGHT: (0, -1),
}
_TEXT_INTERVAL = 0.2  # s of wall time between overlay updates
_MAX_LAG = 0.25  # s: behind real time by more than this, pacing starts over instead of rushing


def steer(
    keycode: int, command: Sequence[float], ranges: Mapping[str, float]
) -> np.ndarray | None:
    """The (2,) command (v* m/s, ω* rad/s) that key `keycode` makes of `command`: arrows step it
    by COMMAND_STEP, space stops (0, 0); clipped to `ranges` ("speed_min", "speed_max",
    "yaw_rate_max"; a resolved env `commands` config's). None for any other key."""
    if keycode == KEY_SPACE:
        target = np.zeros(2)
    elif keycode in _STEERING:
        target = np.asarray(command, np.float64) + COMMAND_STEP * np.array(_STEERING[keycode])
    else:
        return None
    speed = np.clip(target[0], ranges["speed_min"], ranges["speed_max"])
    yaw_rate = np.clip(target[1], -ranges["yaw_rate_max"], ranges["yaw_rate_max"])
    return np.round([speed, yaw_rate], 6)


class Session:
    """What `play` shows, without the viewer: a robot stepped by a pilot, pause and restart.

    `key` may be called from the viewer's thread: it only sets flags, which `advance` acts on.
    """

    def __init__(self, pilot: Pilot, host: HostRobot, seed: int = 0):
        self.pilot, self.host, self.seed = pilot, host, seed
        self.act = pilot.actor()
        self.paused = False
        self.episode = -1
        self._restart_requested = False
        self._steer_to: np.ndarray | None = None
        self.restart()

    def key(self, keycode: int) -> None:
        """The viewer's key callback: R / Backspace restarts; a commanded policy's arrows and
        space steer it (`steer`) and P pauses; otherwise space pauses."""
        commands = self.host.commands
        if commands is not None:
            ranges = self.host.config.commands
            now = commands.velocity if self._steer_to is None else self._steer_to
            steered = steer(keycode, now, ranges)
            if steered is not None:
                self._steer_to = steered
                return
        if keycode == (KEY_SPACE if commands is None else KEY_P):
            self.paused = not self.paused
        elif keycode in (KEY_R, KEY_BACKSPACE):
            self._restart_requested = True

    def restart(self) -> None:
        """A fresh episode: reset with the next noise seed."""
        self.episode += 1
        self._restart_requested, self._steer_to = False, None
        self.obs = self.host.reset((self.seed, self.episode))
        self.last: StepResult | None = None

    @property
    def fell(self) -> bool:
        return self.last is not None and self.last.fell

    def advance(self) -> None:
        """One control step, unless paused or fallen; first a restart if one was asked for."""
        if self._restart_requested:
            self.restart()
        if self._steer_to is not None:
            self.host.commands.steer(self._steer_to)
        if self.paused or self.fell:
            return
        self.last = self.host.step(self.act(self.obs))
        self.obs = self.last.obs

    def overlay(self) -> tuple[str, str]:
        """(labels, values): the viewer's two overlay columns."""
        status = "paused" if self.paused else "fell (R restarts)" if self.fell else "walking"
        rows = [
            ("policy", self.pilot.name),
            ("episode", f"{self.episode}  {status}"),
            ("time", f"{self.host.data.time:.2f} s"),
        ]
        if self.last is not None:
            body = self.last.body
            rows += [
                ("speed", f"{self.last.forward_speed:+.2f} m/s"),
                ("roll / pitch / yaw", _degrees(body.roll, body.pitch, body.yaw)),
                ("slope est. / true", _degrees(self.last.slope_estimate, self.last.slope_truth)),
            ]
        if self.host.commands is not None:
            speed, yaw_rate = self.host.commands.velocity
            rows.append(("command v* / w*", f"{speed:+.2f} m/s / {yaw_rate:+.2f} rad/s"))
        params = self.host.rhythm_parameters()
        if params is not None:
            rows += [
                ("A_k / A_h", f"{params.amplitude_knee:.3f} / {params.amplitude_hip:.3f} rad"),
                ("T", f"{params.period:.3f} s"),
                ("phi1 / phi3", f"{params.phi1:+.2f} / {params.phi3:+.2f} rad"),
            ]
        keys = "space pause" if self.host.commands is None else "arrows steer, space stop, P pause"
        rows.append(("keys", f"{keys}, R restart"))
        return "\n".join(label for label, _ in rows), "\n".join(value for _, value in rows)


def _degrees(*angles: float) -> str:
    return " / ".join(f"{math.degrees(angle):+.1f}" for angle in angles) + " deg"


def display_available() -> bool:
    """Whether a window can open: on Linux, an X11 or Wayland display is set."""
    if not sys.platform.startswith("linux"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def run_viewer(session: Session) -> None:
    """Runs `session` in MuJoCo's passive viewer at real time until the window closes.

    Raises whatever the viewer raises when it cannot start (no OpenGL, no display).
    """
    import glfw  # noqa: PLC0415 -- the viewer's windowing library, needed only here
    from mujoco import viewer as mujoco_viewer  # noqa: PLC0415

    # launch_passive waits forever for a viewer whose thread failed to start GLFW: try it here.
    if not glfw.init():
        raise RuntimeError("GLFW could not be initialised")
    host = session.host
    with mujoco_viewer.launch_passive(
        host.model, host.data, key_callback=session.key, show_left_ui=False, show_right_ui=False
    ) as viewer:
        viewer.cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING
        viewer.cam.trackbodyid = host.model.body(constants.TORSO_BODY).id
        viewer.cam.distance, viewer.cam.azimuth, viewer.cam.elevation = 3.5, 120.0, -20.0
        deadline = next_text = time.perf_counter()
        while viewer.is_running():
            with viewer.lock():
                session.advance()
            # set_texts waits for the next frame (so outside the lock, which the render thread
            # takes): a few times a second, so that slow rendering does not slow the robot.
            if time.perf_counter() >= next_text:
                viewer.set_texts((None, mujoco.mjtGridPos.mjGRID_TOPLEFT, *session.overlay()))
                next_text = time.perf_counter() + _TEXT_INTERVAL
            viewer.sync()
            deadline += host.dt
            lag = time.perf_counter() - deadline
            if lag > _MAX_LAG:
                deadline = next_text = time.perf_counter()
            time.sleep(max(0.0, -lag))


def _no_display_line(args: argparse.Namespace, reason: str) -> str:
    terrain = f" --terrain={args.terrain}" if args.terrain else ""
    return (
        f"quadcos.play: {reason}; render a video instead: python -m quadcos.evaluate"
        f" --policy={args.policy}{terrain} --num_envs=1 --out=eval.json --video=walk.mp4"
    )


def _parser() -> argparse.ArgumentParser:
    return engines.host_parser("python -m quadcos.play", __doc__)


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point; returns the exit status (2, one line on stderr, for bad input or no
    display)."""
    try:
        args, overrides = engines.parse_command(_parser(), argv)
        if args.policy is None:
            raise cli.UsageError("--policy is required")
        pilot = Pilot.load(args.policy, overrides)
        terrain = args.terrain or pilot.spec.training_terrain
        host = HostRobot(terrain, pilot.config, physics=args.physics, commands=args.commands)
        session = Session(pilot, host, args.seed)
    except (ValueError, FileNotFoundError) as error:
        cli.print_error("quadcos.play", error)
        return cli.EXIT_USAGE
    if not display_available():
        reason = "no display (DISPLAY / WAYLAND_DISPLAY unset)"
        print(_no_display_line(args, reason), file=sys.stderr)
        return cli.EXIT_USAGE
    try:
        run_viewer(session)
    except Exception as error:  # noqa: BLE001 -- GLFW / OpenGL failures have many types
        print(_no_display_line(args, f"the viewer cannot start ({error})"), file=sys.stderr)
        return cli.EXIT_USAGE
    return 0


if __name__ == "__main__":
    sys.exit(main())
