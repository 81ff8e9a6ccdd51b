"""Trained command policies against the gaits they started from, condition by condition:

    MENAGERIE_ROOT=DIR python experiments/commands/versus_gait.py --num_envs=128 \
        --out=experiments/commands/versus_gait.json RUN=POLICY_DIR...

measures each RUN's kept policy (POLICY_DIR, e.g. a run's policy_best/) and `gait:POLICY_DIR` —
the run's searched gait under its drive, the zero action, which the untrained actor of step 0
acts within its output scale (0.01) — in the four conditions of issue 58's targets
(experiments/robustness/measure.py: nominal, 40 ms, 50-N pushes, friction 0.4) under random
commands, both on the same episodes (seeds). A RUN may name `gait:POLICY_DIR` alone (runs that
share one start). `--out` keeps the RUNs it already holds (measured with the same --num_envs and
--seconds, else it refuses) and is written after each RUN.
"""

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from table import CONDITIONS
from training_summary import KEYS as EVALUATION_KEYS

HERE = Path(__file__).parent
MEASURE = HERE.parent / "robustness" / "measure.py"
KEYS = EVALUATION_KEYS[:5]  # survival, tracking and attitude: what a condition records


def measure(policy: str, num_envs: int, seconds: float) -> dict:
    """measure.py's four conditions of `policy` under random commands: {condition: KEYS, impl}."""
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "conditions.json"
        subprocess.run(
            [sys.executable, str(MEASURE), f"--policy={policy}", f"--num_envs={num_envs}",
             f"--seconds={seconds}", "--commands=random", "--conditions", *CONDITIONS,
             f"--out={out}"],
            check=True,
        )
        rows = json.loads(out.read_text())["conditions"]
    return {name: {key: rows[name][key] for key in (*KEYS, "impl")} for name in CONDITIONS}


def _run_and_policy(text: str) -> tuple[str, str]:
    """(RUN, POLICY_DIR) of a RUN=POLICY_DIR argument; exits naming a malformed one."""
    run, _, policy = text.partition("=")
    if not run or not policy:
        raise SystemExit(f"versus_gait.py: bad RUN {text!r}: expected RUN=POLICY_DIR")
    return run, policy


def dumps(record: dict) -> str:
    """`record` as JSON with one line per condition: a small record that diffs run by run."""
    lines = ["{"]
    lines += [f" {json.dumps(k)}: {json.dumps(v)}," for k, v in record.items() if k != "runs"]
    runs = []
    for run, entry in record["runs"].items():
        parts = []
        for key, value in entry.items():
            if not isinstance(value, dict):
                parts.append(f"   {json.dumps(key)}: {json.dumps(value)}")
                continue
            rows = ",\n".join(f"    {json.dumps(c)}: {json.dumps(v)}" for c, v in value.items())
            parts.append(f"   {json.dumps(key)}: {{\n{rows}\n   }}")
        runs.append(f"  {json.dumps(run)}: {{\n" + ",\n".join(parts) + "\n  }")
    return "\n".join(lines) + '\n "runs": {\n' + ",\n".join(runs) + "\n }\n}\n"


def main() -> None:
    """Measures each RUN (gait, then kept policy) into --out, written after each RUN."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("runs", nargs="+", metavar="RUN=POLICY_DIR")
    parser.add_argument("--num_envs", type=int, default=128)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    pairs = [_run_and_policy(text) for text in args.runs]  # every RUN checked before measuring

    from quadcos import evaluation

    out = Path(args.out)
    setup = {"num_envs": args.num_envs, "seconds": args.seconds, "commands": "random"}
    record = json.loads(out.read_text()) if out.exists() else {"runs": {}}
    held = {key: record[key] for key in setup if key in record}
    if held and held != setup:  # one record, one setup: its RUNs compare
        raise SystemExit(f"versus_gait.py: {out} holds RUNs measured with {held}, not {setup}")
    record |= setup
    for run, policy in pairs:
        gait = policy if policy.startswith("gait:") else f"gait:{policy}"
        entry = {"gait": measure(gait, args.num_envs, args.seconds)}
        if not policy.startswith("gait:"):
            entry["policy_env_steps"] = evaluation.PolicySpec.parse(policy).env_steps
            entry["kept"] = measure(policy, args.num_envs, args.seconds)
        record["runs"][run] = entry
        out.write_text(dumps(record))
        print(f"versus_gait.py: {run} measured -> {out}", flush=True)


if __name__ == "__main__":
    main()
