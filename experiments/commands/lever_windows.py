"""Several command policies' tracking windows in one small record: where each loses to its gait
(the first 0.5-s window after a command draw, or later; the yaw rate's response step by step after
a draw that turns) and how much its actions change a step (`tracking_windows.py`'s measures, C
MuJoCo under random commands, nothing randomised; no per-window data). The policies:
run folders of `run_gpu.sh` (NAME.tgz unpacked).

    MENAGERIE_ROOT=DIR python experiments/commands/lever_windows.py --episodes=16 \
        --out=experiments/commands/go1_levers_tracking_windows.json \
        go1_tauyaw3eval2_s0:kept=RUNS/go1_tauyaw3eval2_s0/policy_best \
        go1_tauyaw3eval2_s0:last=RUNS/go1_tauyaw3eval2_s0/policy ...
    ... --into=RECORD --out=RECORD [--friction=F] LABEL=DIR ...   # more into an earlier record
"""

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
import numpy as np  # noqa: E402
from tracking_windows import (  # noqa: E402
    SPEED,
    YAW_RATE,
    Recorder,
    action_names,
    episode_series,
    rms,
    windows_of,
)
from training_summary import rounded  # noqa: E402

from quadcos.deploy import host_robot  # noqa: E402

RESPONSE_STEPS = 10  # control steps after a command draw (0.5 s at Go1's 50 ms)
TURN_CHANGE = 0.2  # rad/s: the draws whose ω* changes at least this much


def draw_responses(robot: host_robot.HostRobot, commanded, moved) -> list[np.ndarray]:
    """Per command draw of an episode (after its start) that changes ω* by ≥ TURN_CHANGE: the
    yaw-rate error of its first RESPONSE_STEPS steps, signed by the change (< 0: behind it)."""
    period = round(robot.config.commands.resample_seconds / robot.dt)
    command = np.array(commanded)[:, YAW_RATE]
    rate = np.array(moved)[:, YAW_RATE] if moved else np.zeros(0)
    responses = []
    for start in range(period, len(rate) - RESPONSE_STEPS + 1, period):
        change = command[start] - command[start - 1]
        if abs(change) >= TURN_CHANGE:
            steps = slice(start, start + RESPONSE_STEPS)
            responses.append(np.sign(change) * (rate[steps] - command[steps]))
    return responses


def measure(policy: str, episodes: int, seconds: float, friction: float = 0.0) -> dict:
    """One policy's record beside its zero action's (its gait under the feed-forward alone), on
    ground and feet of sliding `friction` (0: the MJCF's), its floats to 4 decimals."""
    pilot = host_robot.Pilot.load(policy)
    robot = host_robot.HostRobot(
        "flat", pilot.config, physics="training", commands="random", friction=friction
    )
    recorder, zero = Recorder(pilot.actor()), np.zeros(robot.action_size)
    record = {"policy_env_steps": pilot.spec.env_steps, "friction": friction}
    for prefix, act in (("", recorder), ("gait_", lambda obs: zero)):
        windows, responses = [], []
        for seed in range(episodes):
            if act is recorder:
                recorder.start()
            series = episode_series(robot, act, seed, seconds)
            windows += windows_of(robot, *series)
            responses += draw_responses(robot, *series)
        first = [w for w in windows if w.since == 0]
        later = [w for w in windows if w.since > 0]
        record |= {
            f"{prefix}speed_tracking_rms": rms(windows, SPEED),
            f"{prefix}yaw_rate_tracking_rms": rms(windows, YAW_RATE),
            f"{prefix}yaw_rate_rms_first_window": rms(first, YAW_RATE),
            f"{prefix}yaw_rate_rms_later": rms(later, YAW_RATE),
            # the mean signed yaw-rate error per step after a draw that turns (`draw_responses`)
            f"{prefix}turning_draws": len(responses),
            f"{prefix}yaw_rate_error_after_turning_draw": [
                float(value) for value in (np.mean(responses, axis=0) if responses else ())
            ],
        }
    stats = recorder.stats(action_names(robot.config))
    # each action value's RMS change from one control step to the next, in [−1, 1]'s units
    record["action_step_change"] = {name: row["rms_step_change"] for name, row in stats.items()}
    return rounded(record, 4)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("policies", nargs="+", help="LABEL=POLICY_DIR")
    parser.add_argument("--episodes", type=int, default=16)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--friction", type=float, default=0.0, help="sliding friction (0: MJCF's)")
    parser.add_argument("--out", required=True)
    parser.add_argument("--into", help="an earlier record whose policies to keep (others added)")
    args = parser.parse_args()
    pairs = [spec.partition("=")[::2] for spec in args.policies]
    if bad := [label for label, path in pairs if not label or not Path(path).is_dir()]:
        parser.error(f"not LABEL=POLICY_DIR with a policy folder: {bad}")
    record = {"episodes": args.episodes, "seconds": args.seconds, "policies": {}}
    if args.into:
        record = json.loads(Path(args.into).read_text())
        if (record["episodes"], record["seconds"]) != (args.episodes, args.seconds):
            held = f"{record['episodes']} episodes of {record['seconds']} s"
            parser.error(f"{args.into} holds {held}")
    for label, path in pairs:
        record["policies"][label] = row = measure(path, args.episodes, args.seconds, args.friction)
        rates = [row[f"{who}yaw_rate_tracking_rms"] for who in ("", "gait_")]
        firsts = [row[f"{who}yaw_rate_rms_first_window"] for who in ("", "gait_")]
        print(
            f"{label}: yaw rate {rates[0]:.3f} (gait {rates[1]:.3f}), first window"
            f" {firsts[0]:.3f} ({firsts[1]:.3f})",
            flush=True,
        )
    Path(args.out).write_text(_dumps(record))


def _dumps(record: dict) -> str:
    """The record as JSON, a policy a line."""
    rows = ",\n".join(
        f"  {json.dumps(label)}: {json.dumps(row, separators=(',', ':'))}"
        for label, row in record["policies"].items()
    )
    head = f'{{\n "episodes": {record["episodes"]},\n "seconds": {record["seconds"]},\n'
    return head + ' "policies": {\n' + rows + "\n }\n}\n"


if __name__ == "__main__":
    main()
