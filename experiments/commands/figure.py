"""The figure of experiments/commands/README.md: commanded against achieved velocity of each
shipped command policy on one schedule (8 episodes, the first traced; runs on a CPU):

    MENAGERIE_ROOT=DIR python experiments/commands/figure.py
"""

import subprocess
import sys
import tempfile
from pathlib import Path

from quadcos.viz import plots

HERE = Path(__file__).parent
SCHEDULE = "0.5,0@5;1.0,0@5;0.6,0.4@5;0,0@5"
POLICIES = {"Go1": "unitree_go1_command", "Go2": "unitree_go2_command"}


def main() -> None:
    traces = {}
    with tempfile.TemporaryDirectory() as scratch:
        for label, name in POLICIES.items():
            trace = Path(scratch) / f"{name}.json"
            subprocess.run(
                [sys.executable, "-m", "quadcos.evaluate", f"--policy=experiments/policies/{name}",
                 f"--commands={SCHEDULE}", "--num_envs=8", "--seconds=20", "--no_progress",
                 f"--out={Path(scratch) / 'eval.json'}", f"--trace={trace}"],
                check=True,
            )
            traces[label] = plots.load_trace(trace)
    plots.plot_command_tracking(traces, path=HERE.parent.parent / "docs" / "command_tracking.png")


if __name__ == "__main__":
    main()
