"""The trainer's own last evaluation of each run, from the train logs' tails that
`run_gpu.sh wait` writes ($OUT/NAME_train.log), into training_feed_forward.json:

    python experiments/commands/training_summary.py OUT_DIR... > experiments/commands/training_feed_forward.json

Each run: its flags (from the run spec in the log's path name only: NAME), the last
"step ... eval reward ... speed ... fall rate ..." line, and the best evaluation's reward
("best evaluation so far (R)") where the tail holds one.
"""

import json
import re
import sys
from pathlib import Path

STEP = re.compile(
    r"step ([\d,]+)/[\d,]+\s+([\d,]+) env steps/s\s+eval reward (\S+)\s+speed (\S+) m/s"
    r"\s+fall rate (\S+)"
)
BEST = re.compile(r"best evaluation so far \((\S+)\)")


def summary(log: Path) -> dict:
    text = log.read_text()
    steps = STEP.findall(text)
    best = BEST.findall(text)
    env_steps, rate, reward, speed, falls = steps[-1]
    return {
        "last_evaluation": {
            "env_steps": int(env_steps.replace(",", "")),
            "env_steps_per_s": int(rate.replace(",", "")),
            "eval_reward": float(reward),
            "speed": float(speed),
            "fall_rate": float(falls),
        },
        "best_eval_reward": float(best[-1]) if best else None,
    }


if __name__ == "__main__":
    logs = sorted(p for d in sys.argv[1:] for p in Path(d).glob("*_train.log"))
    runs = {log.name.removesuffix("_train.log"): summary(log) for log in logs}
    print(json.dumps({"command": "bash experiments/commands/run_gpu.sh train|wait RUN...", "runs": runs}, indent=1))
