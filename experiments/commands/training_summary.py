"""A campaign's runs in one small record, from the folders `run_gpu.sh evaluate` and `pack` leave
(NAME.tgz, or NAME/ unpacked), into a JSON beside this file:

    python experiments/commands/training_summary.py [--into RECORD] OUT_DIR... > NEW_RECORD
    python experiments/commands/training_summary.py --figure PNG RUN...  # from campaign.json

`--into` keeps the runs of an earlier record (e.g. experiments/commands/campaign.json) and adds or
replaces those of OUT_DIR. `--figure` plots the named runs' training evaluations against their
step-0 gaits and their critics' loss (`quadcos.viz.plots.plot_against_gait`).

Each run: its train flags (`argv`: all but --output_dir and --no_progress, where the run recorded
them; a resumed run's first command's and then each resume's), the feed-forward measured on its gait
(v_ref, b, speed map), every training-time evaluation of the trainer (env steps, eval reward, speed,
fall rate, the env-steps/s of the window it ends, its tracking RMS where logged, and where its
evaluations measured the robustness conditions its worst ratio to step 0 as the gait rank reads it:
`to_step0`, `worst_cell`, and per measure `speed_to_step0`, `yaw_rate_to_step0`; and the learner's
chunk it ends: `train_reward`, `critic_loss`, `alpha`, where packed), the training rate at the last
evaluation, the solver probe's physics (a robot without a preset), the gait tracking measure's
finalists (`sac.gait_search.track_gaits`), and the key numbers of the kept policy's random-command
evaluation and robustness conditions, of its step-0 gait's conditions and of the last policy's
evaluation and conditions (where measured), with the physics they ran on where recorded (per-episode
data left out). The record holds the rows of those tables as lists under its "columns"; `load_runs`
reads them back as dicts."""

import io
import json
import math
import re
import sys
import tarfile
from pathlib import Path

STEP = re.compile(
    r"step ([\d,]+)/[\d,]+\s+([\d,]+) env steps/s\s+eval reward (\S+)\s+speed (\S+) m/s"
    r"\s+fall rate (\S+)(?:\s+speed RMS (\S+) m/s\s+yaw-rate RMS (\S+) rad/s)?"
    r"(?:\s+roll (\S+) rad)?"
)
FEED_FORWARD = re.compile(r"feed-forward: v_ref (\S+) m/s, b (\S+) m(?: .*?speed map \(([^)]*)\))?")
DROPPED = ("--output_dir", "--no_progress")  # argv flags that say nothing of the run
STOPPED = re.compile(r"error: (non-finite SAC loss[^;]*)")
# the gait search's rounds and its result: how many candidates never fell, how long it took
SEARCH_ROUND = re.compile(r"gait search round \d+/\d+ \((\d+) s\): (\d+) of (\d+) candidates")
SEARCH_END = re.compile(  # (runs that logged it: the gait's attitude in the search)
    r"gait search: action centre \S+ \(([\d.]+) m/s, ([\d.]+) % falls"
    r"(?:, roll ([\d.]+) rad, pitch error ([\d.]+) rad)?\) after (\d+) s"
)
# the gait tracking measure's line of each finalist (`sac.gait_search.track_gaits`)
TRACKED = re.compile(
    r"gait tracking #\d+ \S+: ([\d.]+) % falls, ([\d.]+) m/s, ([\d.]+) rad/s, roll ([\d.]+),"
    r" pitch error ([\d.]+) rad(: kept)?"
)
PROBE = re.compile(r"solver probe: ([^(\n]*?) \(")  # a robot without a preset: the physics chosen
KEYS = (
    "success_rate",
    "speed_tracking_rms",
    "yaw_rate_tracking_rms",
    "mean_max_abs_pitch_error",
    "mean_max_abs_roll",
    "cost_of_transport",
    "peak_joint_torque_ratio",
)


def _files(path: Path) -> dict[str, str]:
    """The run's text files by name (the train log as "train.log": a failed first launch's,
    `run_gpu.sh wait`'s NAME.failed.log, then its relaunch's; its best policy's description
    as "policy_best.json")."""
    best = "policy_best/policy.json"
    if path.suffix == ".tgz":
        with tarfile.open(path) as tar:
            members = [m for m in tar.getmembers() if m.isfile()]
            texts = {
                "policy_best.json" if m.name.endswith(best) else Path(m.name).name:
                tar.extractfile(m).read().decode()
                for m in members if "/policy" not in m.name or m.name.endswith(best)
            }
    else:
        texts = {p.name: p.read_text() for p in path.iterdir() if p.is_file()}
        if (path / best).is_file():
            texts["policy_best.json"] = (path / best).read_text()
    name = path.name.removesuffix(".tgz")
    texts["train.log"] = texts.get(f"{name}.failed.log", "") + texts.get(f"{name}.log", "")
    return texts


def _evaluation(text: str | None) -> dict | None:
    if text is None:
        return None
    summary = json.loads(io.StringIO(text).read())
    setup = summary["setup"]
    # the physics it ran on ("jax" or "warp"; evaluations that recorded it)
    physics = {"impl": setup["impl"]} if "impl" in setup else {}
    # Eq. 13's terms per episode (evaluations that recorded them): what the policy traded
    terms = summary.get("mean_reward_terms")
    return {"policy_env_steps": setup["policy_env_steps"], **physics} | {
        key: summary[key] for key in KEYS
    } | ({"reward_terms": {k: round(v, 1) for k, v in terms.items()}} if terms else {})


def summary(path: Path) -> dict:
    files = _files(path)
    log = files["train.log"]
    ff = FEED_FORWARD.search(log)
    stopped = STOPPED.search(log)
    probe = PROBE.search(log)
    rows = STEP.findall(log)
    rounds, found = SEARCH_ROUND.findall(log), SEARCH_END.search(log)
    config = json.loads(files.get("config.json", "{}"))
    metrics = files.get("metrics.jsonl", "")
    smoothness, learner = _chunks(metrics, SMOOTHNESS), _chunks(metrics, LEARNER)
    against_gait = _against_gait(metrics)
    info = config.get("run_info", {})
    # a resumed run's flags: its first command's, then each resume's (a lever forked from a run)
    resumed = [flag for resume in info.get("resumed_argv", []) for flag in resume]
    argv = info.get("argv") and [*info["argv"], *resumed]
    centre = info.get("env", {}).get("action_centre")
    best = json.loads(files.get("policy_best.json", "{}")).get("config", {}).get("best_of_run")
    return {
        **({"argv": [a for a in argv if a.startswith("--") and not a.startswith(DROPPED)]}
           if argv else {}),
        # the searched gait, A_k,A_h,T,phi1,phi3 (runs that recorded their config)
        **({"action_centre": centre} if centre else {}),
        "feed_forward": ff and {
            "reference_speed": float(ff[1]),
            "half_track": float(ff[2]),
            "speed_map": [float(v) for v in ff[3].split(",")] if ff[3] else None,
        },
        "evaluations": [
            {
                "env_steps": int(steps.replace(",", "")),
                "eval_reward": float(reward),
                "speed": float(speed),
                "fall_rate": float(falls),
                # the trainer's rate over the window since the row before (0 at step 0)
                "env_steps_per_s": int(rate.replace(",", "")),
                # the evaluation's tracking RMS (runs that logged it)
                **({"speed_rms": float(speed_rms), "yaw_rate_rms": float(yaw_rms)}
                   if speed_rms else {}),
                # the mean of its episodes' peak roll, rad (runs that logged it)
                **({"roll": float(roll)} if roll else {}),
                # the learner over the chunk the evaluation ends (SMOOTHNESS, LEARNER: runs
                # that logged them)
                **smoothness.get(int(steps.replace(",", "")), {}),
                **learner.get(int(steps.replace(",", "")), {}),
                # against step 0 in each condition's tracking (runs whose evaluations measured
                # the robustness conditions: `_against_gait`)
                **against_gait.get(int(steps.replace(",", "")), {}),
            }
            for steps, rate, reward, speed, falls, speed_rms, yaw_rms, roll in rows
        ],
        # the trainer's env steps per second at its last evaluation (runs that logged it)
        **({"env_steps_per_s": int(rows[-1][1].replace(",", ""))} if len(rows) > 1 else {}),
        **({"solver_probe": probe[1]} if probe else {}),
        # candidates that never fell in each round, the gait kept (runs that logged the search)
        **({"gait_search": {
            "never_fell": [int(kept) for _, kept, _ in rounds],
            "candidates": int(rounds[-1][2]),
            "speed": float(found[1]),
            "fall_percent": float(found[2]),
            **({"roll": float(found[3]), "pitch_error": float(found[4])} if found[3] else {}),
            "seconds": int(found[5]),
        }} if rounds and found else {}),
        # the finalists the gait tracking measure walked, in the search's order (runs with
        # `sac.gait_search.track_gaits`): falls %, speed and yaw-rate RMS, roll, pitch error
        **({"tracked_gaits": [
            {"fall_percent": float(falls), "speed_rms": float(speed), "yaw_rate_rms": float(yaw),
             "roll": float(roll), "pitch_error": float(pitch), "kept": bool(kept)}
            for falls, speed, yaw, roll, pitch, kept in TRACKED.findall(log)
        ]} if TRACKED.search(log) else {}),
        "stopped": stopped[1] if stopped else None,
        "kept": _evaluation(files.get("eval.json")),
        # the env step of the policy its training evaluations kept (runs that packed policy_best;
        # the same as "kept"'s where that was evaluated)
        **({"best_of_run": best["step"]} if best else {}),
        "last": _evaluation(files.get("last_eval.json")),
        "robustness": _conditions(files.get("robustness.json")),
        # its step-0 gait's and its last policy's conditions (runs evaluated with them)
        **{
            key: _conditions(files[f"{key}.json"])
            for key in ("gait_robustness", "last_robustness")
            if f"{key}.json" in files
        },
    }


# the learner's values over the chunk an evaluation ends, by column: the actor's loss and its CAPS
# term (runs with `sac.smoothness` on); the exploring policy's mean reward per stored transition
# (unscaled), the critic's loss and the temperature α
SMOOTHNESS = {"actor_loss": "train/actor_loss", "smoothness": "train/smoothness"}
LEARNER = {
    "train_reward": "train/reward", "critic_loss": "train/critic_loss", "alpha": "train/alpha",
}


def _chunks(metrics: str, columns: dict[str, str]) -> dict[int, dict]:
    """{env step: {column: its metric}} of a metrics.jsonl's rows that hold every metric of
    `columns`."""
    rows = (json.loads(line) for line in metrics.splitlines() if line.strip())
    return {
        row["step"]: {column: row[key] for column, key in columns.items()}
        for row in rows
        if all(key in row for key in columns.values())
    }


def _against_gait(metrics: str) -> dict[int, dict]:
    """{env step: its evaluation against step 0's} of a metrics.jsonl whose evaluations measured
    the robustness conditions (`randomization.eval_conditions`), as `best_policy_by=gait` ranks
    them: the worst ratio of its tracking RMS cells (pooled and per condition, speed and yaw
    rate) to step 0's, that cell ("condition/measure"), the worst ratio among the speed cells and
    among the yaw-rate cells alone (`speed_to_step0`, `yaw_rate_to_step0`: what SAC trades), and
    the conditions where it fell more often than step 0 (where any); none for step 0 itself."""
    from quadcos.training import best_policy

    rows = [json.loads(line) for line in metrics.splitlines() if line.strip()]
    rows = [row for row in rows if best_policy.condition_falls(row)]
    start = next((row for row in rows if row.get("step") == 0), None)
    if start is None:
        return {}
    targets = {key: value for key, value in best_policy.cells(start).items() if value > 0}
    falls = best_policy.condition_falls(start)
    against = {}
    for row in rows:
        if row is start:
            continue
        cells = best_policy.cells(row)
        ratios = {key: cells[key] / target for key, target in targets.items()}
        worst = max(ratios, key=ratios.get)
        more = sorted(
            key.split("/")[1]
            for key, value in best_policy.condition_falls(row).items()
            if value > falls.get(key, math.inf)
        )
        against[row["step"]] = {
            "to_step0": ratios[worst],
            "worst_cell": worst.removeprefix("eval/").removesuffix("_tracking_rms"),
            **{
                f"{cell.removesuffix('_tracking_rms')}_to_step0": max(
                    ratio for key, ratio in ratios.items() if key.endswith(f"/{cell}")
                )
                for cell in (key.removeprefix("eval/") for key in best_policy.TRACKING)
            },
        } | ({"falls_above_step0": more} if more else {})
    return against


def rounded(value, digits: int = 6):
    """`value` with every float in it rounded to `digits` decimals: the tables quote three, the
    strict comparisons against a run's gait (table.py, `shortfalls`) resolve 1e-6."""
    if isinstance(value, float):
        return round(value, digits)
    if isinstance(value, dict):
        return {key: rounded(item, digits) for key, item in value.items()}
    if isinstance(value, list):
        return [rounded(item, digits) for item in value]
    return value


# The record's tables: a run's parts that are lists of rows (or rows by condition) hold each row
# as its values under these columns, the keys written once in the record ("columns"), not in
# every row; a value a row lacks is null (no part holds a null value).
BY_CONDITION = ("robustness", "gait_robustness", "last_robustness")  # {condition: row}
COLUMNS = {
    "evaluations": ("env_steps", "eval_reward", "speed", "fall_rate", "env_steps_per_s",
                    "speed_rms", "yaw_rate_rms", "actor_loss", "smoothness", "roll", "to_step0",
                    "worst_cell", "falls_above_step0", "speed_to_step0", "yaw_rate_to_step0",
                    "train_reward", "critic_loss", "alpha"),
    "tracked_gaits": ("fall_percent", "speed_rms", "yaw_rate_rms", "roll", "pitch_error", "kept"),
    **{key: KEYS[:5] for key in BY_CONDITION},
}


def _tables(run: dict, columns: dict, row) -> dict:
    """`run` with `row(part, values)` applied to each row of each of its tables in `columns`."""
    def table(part: str, value):
        if value is None or part not in columns:
            return value
        if part in BY_CONDITION:
            return {name: row(part, values) for name, values in value.items()}
        return [row(part, values) for values in value]

    return {part: table(part, value) for part, value in run.items()}


def packed(run: dict) -> dict:
    """`run` as the record holds it: each table's rows as lists under `COLUMNS` (trailing
    nulls dropped). A key outside its table's columns is refused: it would be lost."""
    def row(part: str, values: dict) -> list:
        if unknown := set(values) - set(COLUMNS[part]):
            raise ValueError(f"{part}: {sorted(unknown)} not among the record's columns")
        out = [values.get(key) for key in COLUMNS[part]]
        while out and out[-1] is None:
            out.pop()
        return out

    return _tables(run, COLUMNS, row)


def unpacked(run: dict, columns: dict = COLUMNS) -> dict:
    """A run of the record with its tables' rows as dicts again (`packed`'s inverse)."""
    return _tables(
        run, columns,
        lambda part, values: {k: v for k, v in zip(columns[part], values) if v is not None},
    )


def load_runs(path: Path = Path(__file__).with_name("campaign.json")) -> dict[str, dict]:
    """A record's runs by name, each table's rows as dicts (under the record's own columns)."""
    record = json.loads(Path(path).read_text())
    columns = record.get("columns", {})
    return {name: unpacked(run, columns) for name, run in record["runs"].items()}


def _part(key: str, value) -> str:
    """One part of a run as the record's line: its floats `rounded`, no spaces inside."""
    return f"   {json.dumps(key)}: {json.dumps(rounded(value), separators=(',', ':'))}"


def _conditions(text: str | None) -> dict | None:
    """Survival, tracking and attitude per condition of a measure.py record (None: none)."""
    if text is None:
        return None
    rows = json.loads(text)["conditions"]
    return {name: {key: row[key] for key in KEYS[:5]} for name, row in rows.items()}


if __name__ == "__main__":
    args = sys.argv[1:]
    if args[:1] == ["--figure"]:
        from quadcos.viz import plots

        recorded = load_runs()
        unknown = [name for name in args[2:] if name not in recorded]
        if len(args) < 3 or unknown:
            sys.exit(f"usage: --figure PNG RUN... (runs of campaign.json); not there: {unknown}")
        plots.plot_against_gait(
            {name: recorded[name]["evaluations"] for name in args[2:]}, path=args[1]
        )
        sys.exit()
    runs = {}
    if args[:1] == ["--into"]:
        runs = load_runs(args[1])
        args = args[2:]
    paths = sorted(
        p for d in args for p in Path(d).iterdir() if p.suffix == ".tgz" or p.is_dir()
    )
    runs |= {p.name.removesuffix(".tgz"): summary(p) for p in paths}
    command = "bash experiments/commands/run_gpu.sh train|wait|evaluate|pack RUN..."
    # One line per run and per part of a run: a small record that diffs run by run.
    parts = ",\n".join(
        f"  {json.dumps(name)}: {{\n"
        + ",\n".join(_part(key, value) for key, value in packed(run).items())
        + "\n  }"
        for name, run in runs.items()
    )
    columns = json.dumps(COLUMNS, separators=(",", ":"))
    print(
        f'{{\n "command": {json.dumps(command)},\n "columns": {columns},\n'
        f' "runs": {{\n{parts}\n }}\n}}'
    )
