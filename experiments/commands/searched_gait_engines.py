"""A searched gait under the command preset's drive, before SAC: in MJX and in C MuJoCo, with the
drive's loops closed (the preset) and open, on one command schedule, nothing randomised.

    MENAGERIE_ROOT=DIR python experiments/commands/searched_gait_engines.py \
        --out=experiments/commands/anybotics_anymal_c_searched_gait_engines.json

The policy is a run's untrained actor at the gait (`--centre`, with its feed-forward given, as a
search and its calibration leave them): a tiny `--preset=command` run on a CPU, stopped before its
actor learns (the first 2,000 updates train only the critics), whose mean action is the centre.
Defaults: ANYmal C's gait of `anymal_servo300_s0` (campaign.json) with the preset's kp-300 servos.
Each engine's evaluation summary is kept without its per-episode data.
"""

import argparse
import json
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

TINY = [  # a run that ends before the actor's warm-up does (its policy: the centre)
    "--config.sac.num_envs=8", "--config.sac.batch_size=32", "--config.sac.num_eval_envs=8",
    "--config.sac.min_replay_size=64", "--config.sac.num_timesteps=100",
    "--config.sac.replay_size=4096", "--config.sac.eval_episode_length=20",
    "--config.sac.steps_per_chunk=10", "--config.sac.max_seconds=0",
]
LOOPS_OPEN = ["--env.commands.speed_gain_rate=0", "--env.commands.heading_gain=0"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--robot", default="menagerie:anybotics_anymal_c")
    parser.add_argument("--centre", default="0.331842,0.13202,0.15185,0.993137,-2.14846")
    parser.add_argument("--feed_forward", default="0.74,0.843,0.1702,0.3542,0.5455,0.7422",
                        help="v_ref, b, then the speed map")
    parser.add_argument("--commands", default="0.4,0@5;0.8,0@5;0.5,0.3@5;0,0@5")
    parser.add_argument("--episodes", type=int, default=16, help="C MuJoCo; MJX: a quarter")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    v_ref, b, *speed_map = args.feed_forward.split(",")
    gait = [f"--config.env.action_centre={args.centre}",
            f"--config.env.commands.reference_speed={v_ref}",
            f"--config.env.commands.half_track={b}",
            f"--config.env.commands.speed_map={','.join(speed_map)}"]
    common = [f"--commands={args.commands}", "--seconds=20", "--no_progress"]
    summaries = {}
    with tempfile.TemporaryDirectory() as scratch:
        run = Path(scratch) / "run"
        subprocess.run([sys.executable, "-m", "quadcos.train", "--preset=command",
                        f"--robot={args.robot}", f"--output_dir={run}", "--no_progress",
                        *gait, *TINY], check=True, stdout=subprocess.DEVNULL)
        mjx = ["quadcos.evaluate", "--terrain=flat", f"--num_envs={max(args.episodes // 4, 1)}",
               "--env.randomization.enabled=false"]
        mujoco = ["quadcos.sim2sim", f"--episodes={args.episodes}"]
        for loops, flags in (("loops closed", []), ("loops open", LOOPS_OPEN)):
            for engine, command in (("MJX (JAX)", mjx), ("C MuJoCo", mujoco)):
                out = Path(scratch) / "eval.json"
                subprocess.run([sys.executable, "-m", *command, f"--policy={run / 'policy'}",
                                *common, *flags, f"--out={out}"], check=True)
                summary = json.loads(out.read_text())
                summary.pop("episodes", None)
                summaries[f"{engine}, {loops}"] = summary
    record = {
        "command": "python experiments/commands/searched_gait_engines.py " + " ".join(
            shlex.quote(f"--{key}={value}") for key, value in vars(args).items() if key != "out"),
        "robot": args.robot, "centre": args.centre, "feed_forward": args.feed_forward,
        "commands": args.commands, "engines": summaries,
    }
    Path(args.out).write_text(json.dumps(record, separators=(",", ":")) + "\n")
    for label, s in summaries.items():
        print(f"{label}: {s['success_rate'] * s['num_episodes']:.0f} / {s['num_episodes']},"
              f" {s['speed_tracking_rms']:.3f} m/s, {s['yaw_rate_tracking_rms']:.3f} rad/s,"
              f" pitch error {s['mean_max_abs_pitch_error']:.3f},"
              f" roll {s['mean_max_abs_roll']:.3f}")


if __name__ == "__main__":
    main()
