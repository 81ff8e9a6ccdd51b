"""Several command policies' tracking windows in one small record: where each loses to its gait
(the first 0.5-s window after a command draw, or later; the bias per commanded ω*) and how its
actions move (`tracking_windows.py`'s measures, C MuJoCo under random commands, nothing
randomised; no per-window data). The policies: run folders of `run_gpu.sh` (NAME.tgz unpacked).

    MENAGERIE_ROOT=DIR python experiments/commands/lever_windows.py --episodes=16 \
        --out=experiments/commands/go1_levers_tracking_windows.json \
        go1_tauyaw3eval2_s0:kept=RUNS/go1_tauyaw3eval2_s0/policy_best \
        go1_tauyaw3eval2_s0:last=RUNS/go1_tauyaw3eval2_s0/policy ...
    ... --into=RECORD --out=RECORD LABEL=DIR ...   # more policies into an earlier record
"""

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from tracking_windows import (  # noqa: E402
    SPEED,
    YAW_RATE,
    Recorder,
    action_names,
    by_command,
    rms,
    window_errors,
)

import numpy as np  # noqa: E402

from quadcos.deploy import host_robot  # noqa: E402


def measure(policy: str, episodes: int, seconds: float) -> dict:
    """One policy's record beside its zero action's (its gait under the feed-forward alone)."""
    pilot = host_robot.Pilot.load(policy)
    robot = host_robot.HostRobot("flat", pilot.config, physics="training", commands="random")
    recorder, zero = Recorder(pilot.actor()), np.zeros(robot.action_size)
    record = {"policy_env_steps": pilot.spec.env_steps}
    for prefix, act in (("", recorder), ("gait_", lambda obs: zero)):
        windows = []
        for seed in range(episodes):
            if act is recorder:
                recorder.start()
            windows += window_errors(robot, act, seed, seconds)
        first = [w for w in windows if w.since == 0]
        later = [w for w in windows if w.since > 0]
        record |= {
            f"{prefix}speed_tracking_rms": rms(windows, SPEED),
            f"{prefix}yaw_rate_tracking_rms": rms(windows, YAW_RATE),
            f"{prefix}yaw_rate_rms_first_window": rms(first, YAW_RATE),
            f"{prefix}yaw_rate_rms_later": rms(later, YAW_RATE),
            # past the first window, the mean yaw-rate error per 0.2-rad/s bin of ω*
            f"{prefix}yaw_rate_bias_by_command": [
                round(row["mean_error"], 4) for row in by_command(windows, YAW_RATE)
            ],
        }
    record["action_stats"] = recorder.stats(action_names(robot.config))
    return record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("policies", nargs="+", help="LABEL=POLICY_DIR")
    parser.add_argument("--episodes", type=int, default=16)
    parser.add_argument("--seconds", type=float, default=20.0)
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
            parser.error(f"{args.into} holds {record['episodes']} episodes of {record['seconds']} s")
    for label, path in pairs:
        record["policies"][label] = row = measure(path, args.episodes, args.seconds)
        print(
            f"{label}: yaw rate {row['yaw_rate_tracking_rms']:.3f} (gait"
            f" {row['gait_yaw_rate_tracking_rms']:.3f}), first window"
            f" {row['yaw_rate_rms_first_window']:.3f} ({row['gait_yaw_rate_rms_first_window']:.3f})",
            flush=True,
        )
    Path(args.out).write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
