"""The per-env-step numbers of docs/benchmarks.md ("Where the time goes") from this folder's files,
as the JSON its results record (`results/profile_h100.json`) summarises:

    python benchmarks/h100/profile/per_step.py benchmarks/h100/profile > benchmarks/h100/profile/per_step.json
    python -m quadcos.results record --name=profile_h100 --device="NVIDIA H100 80GB HBM3" \
        --claim="Where a training step's time goes on one H100" \
        --command="python benchmarks/h100/profile/per_step.py benchmarks/h100/profile" \
        benchmarks/h100/profile/per_step.json

Reads `bench_warp_{flat,slope5}_profiled.json` (rates) and `profile_{terrain}_{row}.md` (the
output of `python -m quadcos.benchmarking.profile`: the trace's span, the GPU stream's busy time by
kind). The trace holds the `TRACED_CHUNKS` chunks that `quadcos.bench --profile_dir` traces, of
the training preset's `steps_per_chunk` env steps each; each kind's seconds over that count is its
time per env step (the GPU's own durations); wall = the untraced rate's time per env step (tracing
slows the host, so the trace's span is longer); idle = wall − busy (the stream's merged busy
intervals; kinds that overlap, such as a copy beside a kernel, can sum to more than busy).
"""

import json
import pathlib
import re
import sys

from quadcos.benchmarking import settings

KINDS = {"warp (physics)": "warp", "fusion": "fusion", "matmul": "matmul", "copy": "copy"}
TRACED_CHUNKS = 2  # quadcos.benchmarking.trainers.measure_trainer


def gpu_stream(text: str) -> dict[str, float]:
    """Busy seconds of the GPU stream's timeline, by kind and in all ("busy"), and the span."""
    span = float(re.search(r"trace span ([\d.]+) s", text).group(1))
    busy = float(re.search(r"^\| /device:GPU:0 \| [^|]+\| \d+ \| ([\d.]+) \|", text, re.M).group(1))
    section = text[text.index("**/device:GPU:0") :]
    section = section[: section.find("\n**", 1) if "\n**" in section[1:] else len(section)]
    found = re.findall(r"^\| kind: ([^|]+?) \| ([\d.]+) \|", section, re.M)
    kinds = {kind: float(seconds) for kind, seconds in found}
    return {"span": span, "busy": busy, **kinds}


def rows(folder: pathlib.Path) -> list[dict]:
    """One row per training row profiled: its rate, its ratio to the raw physics, and its time per
    env step in ms (wall; by kind of GPU work; idle)."""
    found = []
    for terrain in ("flat", "slope5"):
        bench = json.loads((folder / f"bench_warp_{terrain}_profiled.json").read_text())
        for row in bench["train"]:
            envs, batch, updates = row["num_envs"], row["batch_size"], row["updates_per_step"]
            rate = row["quadcos_env_steps_per_s"]
            text = (folder / f"profile_{terrain}_{envs}x{batch}x{updates}.md").read_text()
            stream = gpu_stream(text)
            preset = bench["settings"]["training_preset"]
            steps = TRACED_CHUNKS * settings.trainer_config(preset).steps_per_chunk
            per_step = {key: 1e3 * value / steps for key, value in stream.items()}
            wall = 1e3 * envs / rate
            found.append(
                {
                    "terrain": terrain,
                    "updates_per_step": updates,
                    "env_steps_per_s": rate,
                    "to_raw_physics": rate / row["physics_env_steps_per_s"],
                    "wall_ms": wall,
                    **{f"{name}_ms": per_step.get(kind, 0.0) for kind, name in KINDS.items()},
                    "idle_ms": wall - per_step["busy"],
                }
            )
    return found


if __name__ == "__main__":
    print(json.dumps({"rows": rows(pathlib.Path(sys.argv[1]))}, indent=1))
