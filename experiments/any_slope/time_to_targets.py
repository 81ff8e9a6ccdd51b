r"""The any-slope preset's time to its targets, one row per run, from the seeds tables of single
runs and the records of populations (`--population=N`):

    python experiments/any_slope/time_to_targets.py --single experiments/any_slope/seeds_cold_warm.json \
        --population experiments/any_slope/population/pop2_s0 --out benchmarks/h200_time_to_targets.json

A `--single` file is seeds.py's output (one GPU a run); a `--population` PREFIX names
PREFIX.json (the population's `population.json`) and PREFIX_members.json (seeds.py's rows of its
members, evaluated like single runs). The targets (README.md): test set 2026 mean course success
>= 0.97 and worst course >= 0.90, flat attitude (the largest mean of max |pitch error|, |roll|,
|yaw|) <= 0.05 rad. `seconds_to_targets`: process start until the kept policy was written (a single
run) or until the population chose its member (`wall_time_s`: training and selection), null where
the policy misses a target; `seconds` that time whether or not the policy meets them;
`first_chunk_s` process start to the first training chunk (a population: its slowest member's).
Prints the rows as a Markdown table."""

import argparse
import json
import pathlib
import sys

import seeds  # this folder's: the Markdown table

TARGETS = {"testset2026_mean": 0.97, "testset2026_worst": 0.90}
MAX_FLAT_ATTITUDE = 0.05


def meets(row: dict) -> bool:
    """Whether a seeds row's kept policy meets every target (a missing evaluation misses)."""
    values = [row.get(key) for key in (*TARGETS, "flat_max_attitude_rad")]
    if any(value is None for value in values):
        return False
    return all(row[key] >= low for key, low in TARGETS.items()) and (
        row["flat_max_attitude_rad"] <= MAX_FLAT_ATTITUDE
    )


def _row(
    run: str, devices: int, seed: int, cache: str, first_chunk_s: float, seconds: float,
    policy: dict,
) -> dict:
    return {
        "run": run, "num_devices": devices, "seed": seed, "cache": cache,
        "first_chunk_s": first_chunk_s, "seconds": round(seconds, 1),
        "seconds_to_targets": round(seconds, 1) if meets(policy) else None,
        "testset2026_mean": policy["testset2026_mean"],
        "testset2026_worst": policy["testset2026_worst"],
        "flat_max_attitude_rad": policy["flat_max_attitude_rad"],
        "env_steps": policy["env_steps"],
    }


def single_rows(path: pathlib.Path) -> list[dict]:
    """One row per run of a seeds.py file: run names any_slope_{cold,warm}_sSEED say the caches."""
    return [
        _row(row["run"], 1, row["seed"], "cold" if "_cold_" in row["run"] else "warm",
             row["first_chunk_s"], row["train_seconds"], row)
        for row in json.loads(path.read_text())
    ]


def population_row(prefix: pathlib.Path) -> dict:
    """The row of a population: its chosen member's evaluations, its seed the population's."""
    record = json.loads(prefix.with_name(prefix.name + ".json").read_text())
    members = json.loads(prefix.with_name(prefix.name + "_members.json").read_text())
    if record["chosen"] is None:
        raise ValueError(f"{prefix}.json: the population chose no member")
    seeds = {member["index"]: member["seed"] for member in record["members"]}
    chosen = next(row for row in members if row["seed"] == seeds[record["chosen"]])
    return {
        **_row(prefix.name, record["size"], seeds[0], "cold",
               max(row["first_chunk_s"] for row in members), record["wall_time_s"], chosen),
        "chosen_seed": chosen["seed"],
        "members_testset2026": [[row["testset2026_mean"], row["testset2026_worst"]]
                                for row in members],
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--single", type=pathlib.Path, nargs="*", default=[])
    parser.add_argument("--population", type=pathlib.Path, nargs="*", default=[])
    parser.add_argument("--out", type=pathlib.Path, required=True)
    args = parser.parse_args(argv)
    rows = [row for path in args.single for row in single_rows(path)]
    rows += [population_row(prefix) for prefix in args.population]
    if not rows:
        print("time_to_targets.py: give --single or --population", file=sys.stderr)
        return 2
    targets = {**TARGETS, "flat_max_attitude_rad": MAX_FLAT_ATTITUDE}
    lines = ",\n".join(f"  {json.dumps(row)}" for row in rows)  # a row a line
    args.out.write_text(f'{{\n "targets": {json.dumps(targets)},\n "rows": [\n{lines}\n ]\n}}\n')
    seeds.print_table(rows, [key for key in rows[0] if not key.startswith("members_")])
    return 0


if __name__ == "__main__":
    sys.exit(main())
