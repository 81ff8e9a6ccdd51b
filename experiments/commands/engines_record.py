"""The sim-to-sim records of experiments/commands/README.md ("Sim-to-sim"): each command policy of
table.py's ENGINE_RUNS on its schedule in MJX, in C MuJoCo and in C MuJoCo from its ONNX export
(20-s episodes, nominal physics; runs on a CPU):

    MENAGERIE_ROOT=DIR python experiments/commands/engines_record.py [NAME...]   # NAME_engines.json
"""

import json
import subprocess
import sys
import tempfile
from pathlib import Path

from table import ENGINE_RUNS, HERE, POLICIES, SCHEDULE, SCHEDULES


def measure_engines(name: str, episodes: int = 64) -> None:
    """NAME_engines.json: the policy of ENGINE_RUNS[NAME] on its schedule (SCHEDULES, else
    SCHEDULE) with its flags, nominal physics, `episodes` episodes of 20 s in MJX
    (quadcos.evaluate), C MuJoCo (quadcos.sim2sim) and C MuJoCo with its ONNX export; each
    engine's evaluation summary without its per-episode data."""
    policy_name, flags = ENGINE_RUNS[name]
    policy = POLICIES / policy_name
    schedule = SCHEDULES.get(name, SCHEDULE)
    common = [f"--commands={schedule}", "--seconds=20", "--no_progress", *flags]
    summaries = {}
    with tempfile.TemporaryDirectory() as scratch:
        onnx = Path(scratch) / f"{name}.onnx"
        runs = {
            "MJX (JAX)": ["quadcos.evaluate", f"--policy={policy}", "--terrain=flat",
                          f"--num_envs={episodes}", "--env.randomization.enabled=false"],
            "C MuJoCo": ["quadcos.sim2sim", f"--policy={policy}", f"--episodes={episodes}"],
            "C MuJoCo, ONNX policy": ["quadcos.sim2sim", f"--policy={onnx}",
                                      f"--episodes={episodes}"],
        }
        subprocess.run([sys.executable, "-m", "quadcos.export", f"--policy={policy}",
                        f"--out={onnx}"], check=True)
        for label, args in runs.items():
            out = Path(scratch) / "eval.json"
            subprocess.run([sys.executable, "-m", *args, *common, f"--out={out}"], check=True)
            summary = json.loads(out.read_text())
            summary.pop("episodes", None)
            summaries[label] = summary
    record = {"policy": f"experiments/policies/{policy_name}", "flags": list(flags),
              "commands": schedule, "engines": summaries}
    (HERE / f"{name}_engines.json").write_text(json.dumps(record, separators=(",", ":")) + "\n")


if __name__ == "__main__":
    names = sys.argv[1:] or list(ENGINE_RUNS)
    unknown = [name for name in names if name not in ENGINE_RUNS]
    if unknown:
        known = ", ".join(ENGINE_RUNS)
        sys.exit(f"engines_record.py: unknown {', '.join(unknown)}; known: {known}")
    for record_name in names:
        measure_engines(record_name)
