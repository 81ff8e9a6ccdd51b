"""The commanded-gait tables of experiments/commands/README.md, from the evaluation and
robustness JSONs beside this file (`run_gpu.sh evaluate` writes them; per-episode data removed),
the policies' configs and the campaign's runs in campaign.json (`training_summary.py`); and its
figure (commanded against achieved velocity of each shipped command policy on its schedule: 8
episodes, the first traced; runs on a CPU; the sim-to-sim records: engines_record.py):

    python experiments/commands/table.py            # the rows of every table
    python experiments/commands/table.py --check    # exit 1 where README.md's tables differ
    MENAGERIE_ROOT=DIR python experiments/commands/table.py --figure   # docs/command_tracking.png
"""

import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import run_labels as labels
from training_summary import load_runs

HERE = Path(__file__).parent
POLICIES = HERE.parent / "policies"
# column -> the policy folder it evaluates (None: the policy is not kept)
RUNS = {
    "unitree_go1": "unitree_go1_command",
    "unitree_go1_nofeed": None,
    "unitree_go2": "unitree_go2_command",
    "anybotics_anymal_c": "anybotics_anymal_c_command",
}
CONDITIONS = ("nominal", "latency 40 ms", "pushes 50 N, 0.1 s", "friction 0.4")
TARGETS = {  # issue 58's targets, 1024 episodes of 20 s, commands resampled every 5 s
    "survival": "≥ 0.99 each",
    "speed_tracking_rms": "≤ 0.10 m/s",
    "yaw_rate_tracking_rms": "≤ 0.15 rad/s",
    "mean_max_abs_pitch_error": "≤ 0.10 rad",
    "mean_max_abs_roll": "≤ 0.10 rad",
}


def _row(label: str, target: str, cells: list[str]) -> str:
    return f"| {label} | {target} | " + " | ".join(cells) + " |"


def _campaign() -> dict:
    """The campaign's runs by name (campaign.json, training_summary.py)."""
    return load_runs(HERE / "campaign.json")


def _load(name: str) -> dict | None:
    path = HERE / name
    return json.loads(path.read_text()) if path.exists() else None


def _survival(robust: dict | None) -> str:
    return "—" if robust is None else _rates(robust["conditions"][c] for c in CONDITIONS)


def _rates(conditions) -> str:
    """A survival cell: each robustness condition's success rate, "a / b / c / d"."""
    return " / ".join(f"{c['success_rate']:.3f}" for c in conditions)


def _tracking(values: dict) -> str:
    """A tracking cell: "speed RMS, yaw-rate RMS" of an evaluation or a condition."""
    return f"{values['speed_tracking_rms']:.3f}, {values['yaw_rate_tracking_rms']:.3f}"


def table() -> str:
    evals = {r: _load(f"{r}_eval.json") for r in RUNS}
    robust = {r: _load(f"{r}_robustness.json") for r in RUNS}
    commands = {r: e["setup"]["env"]["commands"] for r, e in evals.items()}
    lines = [
        "| | target | " + " | ".join(f"`{r}`" for r in RUNS) + " |",
        "|---" * (len(RUNS) + 2) + "|",
        _row("feed-forward: v_ref m/s, b m (map: a speed map)", "", [
            f"{c['reference_speed']:.2f}, {c['half_track']:.2f}{', map' * bool(c.get('speed_map'))}"
            if c.get("feed_forward") else "off"
            for c in commands.values()
        ]),
        _row("`policy_env_steps`", "",
             [f"{e['setup']['policy_env_steps']:,}" for e in evals.values()]),
        _row("survival, 1024 episodes: " + " / ".join(CONDITIONS), TARGETS["survival"],
             [_survival(robust[r]) for r in RUNS]),
        _row("survival, random commands (episodes)", "",
             [f"{e['success_rate']:.3f} ({e['num_episodes']})" for e in evals.values()]),
        _row("mean forward speed, m/s", "",
             [f"{e['mean_forward_speed']:.2f}" for e in evals.values()]),
    ]
    for key in ("speed_tracking_rms", "yaw_rate_tracking_rms", "mean_max_abs_pitch_error",
                "mean_max_abs_roll"):
        lines.append(_row(f"`{key}`", TARGETS[key], [f"{e[key]:.3f}" for e in evals.values()]))
    for key in ("cost_of_transport", "peak_joint_torque_ratio"):
        cells = ["—" if e[key] is None else f"{e[key]:.2f}" for e in evals.values()]
        lines.append(_row(f"`{key}`", "", cells))
    lines.append(_row("kept policy written, s from the process start (`best_of_run`)", "≤ 600 s",
                      [_written(policy) for policy in RUNS.values()]))
    return "\n".join(lines)


def _written(policy: str | None) -> str:
    """When the run wrote the kept policy (its policy.json), "—" where the policy is not kept."""
    if policy is None:
        return "—"
    config = json.loads((POLICIES / policy / "policy.json").read_text())["config"]
    return f"{config['best_of_run']['written_at_s']:.0f}"


def levers() -> str:
    """The rows of the levers table: each run's last evaluation in training."""
    runs = json.loads((HERE / "training_feed_forward.json").read_text())["runs"]
    rows = []
    for name, change in labels.LEVERS.items():
        e = runs[name]["last_evaluation"]
        rows.append(
            f"| `{name}` | {change} | {e['env_steps'] / 1e6:.1f} M | {e['eval_reward']:.0f} |"
            f" {e['speed']:.3f} | {e['fall_rate']:.3f} |"
        )
    return "\n".join(rows)


GAIN_RECORDS = tuple(  # the drive's gain, and with it its heading loop, 1024 episodes each
    HERE.parent.parent / "results" / f"{name}.json"
    for name in (
        "commands_speed_gain_1024", "commands_heading_loop_1024", "commands_go2_loops_1024"
    )
)
LOOPS_POLICIES = {  # robot -> its run trained with the loops open, that run's JSONs' stem here
    "go1": ("go1_rate_s0", "unitree_go1_no_loops"),
    "go2": ("go2long_s0", "unitree_go2_no_loops"),
}


def gain() -> str:
    """The rows of the drive's-loops table: each policy trained without the loops (its evaluation
    and robustness JSONs here) with them open, with the gain at 1/s and with the heading loop at
    2/s too (the records' sources); then Go1's policy trained with both (campaign.json). 1024
    episodes each."""
    sources = {
        Path(source["path"]).stem: source["summary"]
        for record in GAIN_RECORDS
        for source in json.loads(record.read_text())["sources"]
    }
    runs = []
    for robot, (policy, stem) in LOOPS_POLICIES.items():
        runs += [
            (policy, "off", _load(f"{stem}_eval.json"), _load(f"{stem}_robustness.json")),
            (policy, "1/s", sources[f"{robot}_gain_rate1_eval"],
             sources[f"{robot}_gain_rate1_robustness"]),
            (policy, "1/s, heading loop 2/s", sources[f"{robot}_gain_heading_eval"],
             sources[f"{robot}_gain_heading_robustness"]),
        ]
    trained = _campaign()["go1loops_s1"]
    runs.append(("go1loops_s1", "1/s, heading loop 2/s, in training too", trained["kept"],
                 {"conditions": trained["robustness"]}))
    return "\n".join(
        f"| `{policy}` | {loops} | {evaluation['success_rate']:.3f} |"
        f" {_tracking(evaluation)} | {evaluation['mean_max_abs_pitch_error']:.3f},"
        f" {evaluation['mean_max_abs_roll']:.3f} | {_survival(robust)} |"
        f" {_tracking(robust['conditions']['nominal'])} |"
        for policy, loops, evaluation, robust in runs
    )


def flag(argv: list[str], name: str) -> str:
    """The value of `name`=VALUE in a run's recorded train flags."""
    return next(arg.split("=", 1)[1] for arg in argv if arg.startswith(f"{name}="))


def seeds(names: tuple[str, ...]) -> str:
    """The rows of a seeds table: each run's kept policy under random commands with the training
    randomisation and in the four robustness conditions (nominal: none drawn); the first cell
    names the run, its robot and seed."""
    runs = _campaign()
    rows = []
    for name in names:
        run, kept = runs[name], runs[name]["kept"]
        conditions = run["robustness"]
        nominal = conditions["nominal"]
        robot = flag(run["argv"], "--robot").split(":")[-1]
        first = f"`{name}`: {robot}, seed {flag(run['argv'], '--seed')}"
        rows.append(
            f"| {first} | {kept['policy_env_steps'] / 1e6:.1f} M | "
            + _rates(conditions.values())
            + f" | {_tracking(kept)} |"
            f" {_tracking(nominal)} |"
            f" {kept['mean_max_abs_pitch_error']:.3f}, {kept['mean_max_abs_roll']:.3f} |"
        )
    return "\n".join(rows)


def sac_levers(levers: dict[str, str] = labels.SAC_LEVERS, gait: bool = False) -> str:
    """The rows of a SAC levers table: the trainer's reward from the start to its last
    evaluation, the kept policy, and its survival and tracking (speed, yaw rate) in each
    condition; with `gait`, a first row of the runs' common start (step-0 gait) and where each
    run's kept and last policies do worse than it (`_worse`)."""
    runs = _campaign()
    rows = [_gait_row(levers, runs)] if gait else []
    for name, change in levers.items():
        run = runs[name]
        first, last = run["evaluations"][0], run["evaluations"][-1]
        conditions = run["robustness"].values()
        verdicts = ""
        if gait:
            start, final = run.get("gait_robustness"), run.get("last_robustness")
            verdicts = (
                f" {_worse(run['robustness'], start)} |"
                f" {run['last']['policy_env_steps'] / 1e6:.1f} M: {_worse(final, start)} |"
            )
        rows.append(
            f"| `{name}` | {change} | {first['eval_reward']:.0f} → {last['eval_reward']:.0f}"
            f" ({last['env_steps'] / 1e6:.1f} M) | {run['kept']['policy_env_steps'] / 1e6:.1f} M | "
            + _rates(conditions) + " | "
            + " | ".join(_tracking(c) for c in conditions) + " |" + verdicts
        )
    return "\n".join(rows)


def _gait_row(levers: dict[str, str], runs: dict) -> str:
    """The step-0 gait's row of a levers table from one start: its conditions as measured beside
    the first run, and the most its measurements beside the runs differ (the GPU's
    repeatability)."""
    measured = [runs[name]["gait_robustness"] for name in levers if "gait_robustness" in runs[name]]
    spread = max(
        max(m[c][key] for m in measured) - min(m[c][key] for m in measured)
        for c in measured[0] for key in AGAINST_GAIT
    )
    first = measured[0].values()
    return (
        f"| step-0 gait | the start of every run: measured beside each of {len(measured)}, the"
        f" measurements differ by at most {spread:.4f} | — | 0.0 M | {_rates(first)} | "
        + " | ".join(_tracking(c) for c in first) + " | — | — |"
    )


# measure.py's conditions and `shortfalls`' measures as the levers tables' verdicts name them
SHORT = {"latency 40 ms": "40 ms", "pushes 50 N, 0.1 s": "pushes", "success": "survival"}


def _worse(policy: dict | None, gait: dict | None) -> str:
    """`shortfalls` by measure, its conditions named short ("yaw: 40 ms, pushes"); "none" where
    the policy does no worse than its gait anywhere, "not measured" without both."""
    if not policy or not gait:
        return "not measured"
    conditions: dict[str, list[str]] = {}
    for item in shortfalls(policy, gait):
        condition, measure = item.rsplit(": ", 1)
        named = SHORT.get(measure, measure)
        conditions.setdefault(named, []).append(SHORT.get(condition, condition))
    return "; ".join(f"{m}: {', '.join(c)}" for m, c in conditions.items()) or "none"


def versus_gait() -> str:
    """The rows of the step-0 table (versus_gait.py): each run's searched gait under its drive
    (the zero action, step 0) and its kept policy, survival and tracking in each condition."""
    record = _load("versus_gait.json")
    rows = []
    for name, run in record["runs"].items():
        policies = [("step-0 gait", 0, run["gait"])]
        if "kept" in run:
            policies.append(("kept policy", run["policy_env_steps"], run["kept"]))
        rows += [_policy_row(name, *policy) + " |" for policy in policies]
    return "\n".join(rows)


def _policy_row(name: str, label: str, steps: int | None, conditions: dict) -> str:
    """A step-0 table row without its closing bar: the run, the policy and its env steps of
    SAC, then survival; speed, yaw-rate tracking in each condition."""
    steps = "—" if steps is None else f"{steps / 1e6:.1f} M"
    cells = (f"{c['success_rate']:.3f}; {_tracking(c)}" for c in conditions.values())
    return f"| `{name}` | {label}, {steps} | " + " | ".join(cells)


AGAINST_GAIT = ("success_rate", "speed_tracking_rms", "yaw_rate_tracking_rms")


def shortfalls(kept: dict, gait: dict) -> list[str]:
    """Where a policy does not beat its step-0 gait: "condition: measure" for each condition (of
    `kept` and `gait`, a measure.py record's conditions) where it survives less often or tracks
    speed or the yaw rate worse (issue 58, item 4: the kept policy must beat its gait in every
    condition); none where it is no worse in any of the three anywhere."""
    worse = []
    for name, row in kept.items():
        for key in AGAINST_GAIT:
            sign = -1 if key == "success_rate" else 1  # survival: more is better
            if sign * (row[key] - gait[name][key]) > 0:
                worse.append(f"{name}: {key.split('_')[0]}")
    return worse


def against_gait() -> str:
    """The rows of the kept-against-gait table: each run of campaign.json whose step-0 gait was
    measured in the four conditions beside its kept (unless step 0) and last policies (run_gpu.sh
    evaluate): survival; speed, yaw-rate tracking per condition, and where each falls short."""
    runs = _campaign()
    rows = []
    for name, run in runs.items():
        if "gait_robustness" not in run or name in labels.GO1_LEVERS:  # in their levers' table
            continue
        gait = run["gait_robustness"]
        policies = [("step-0 gait", 0, gait)]
        if run["kept"]["policy_env_steps"]:  # a kept step 0 is the gait under the untrained actor
            policies.append(("kept policy", run["kept"]["policy_env_steps"], run["robustness"]))
        if run["last"] and run.get("last_robustness"):
            last = run["last"]["policy_env_steps"]
            policies.append(("last policy", last, run["last_robustness"]))
        for label, steps, conditions in policies:
            verdict = "; ".join(shortfalls(conditions, gait)) or "no worse anywhere"
            verdict = verdict if steps else "—"
            rows.append(_policy_row(name, label, steps, conditions) + f" | {verdict} |")
    return "\n".join(rows)


def campaign() -> str:
    """The rows of the campaign table: each run's feed-forward, kept and last policy."""
    runs = _campaign()
    rows = []
    for name, drive in labels.CAMPAIGN.items():
        run, kept, last = runs[name], runs[name]["kept"], runs[name]["last"]
        survival = _rates((run["robustness"] or {}).values()) or "not measured"
        rows.append(
            f"| `{name}` | {drive} | {kept['policy_env_steps'] / 1e6:.1f} M | {survival} |"
            f" {_tracking(kept)} | {kept['mean_max_abs_pitch_error']:.3f},"
            f" {kept['mean_max_abs_roll']:.3f} |"
            + (f" {last['policy_env_steps'] / 1e6:.1f} M: {_tracking(last)} |" if last
               else f" stopped: {run['stopped'].split(' in the chunk')[0]} |")
        )
    return "\n".join(rows)


def anymal() -> str:
    """The rows of the ANYmal C levers table: the searched period, the step-0 and kept policies'
    training evaluations, the kept policy's survival in the four conditions, its pitch error
    (nominal) and its tracking under random commands with the training randomisation."""
    runs = _campaign()
    rows = []
    for name, change in labels.ANYMAL.items():
        run, kept = runs[name], runs[name]["kept"]
        conditions = run["robustness"] or {}
        period = float(run["action_centre"].split(",")[2])
        pitch = conditions.get("nominal", {}).get("mean_max_abs_pitch_error")
        rows.append(
            f"| `{name}` | {change} | {period:.3f} | {run['evaluations'][0]['fall_rate']:.3f} |"
            f" {kept['policy_env_steps'] / 1e6:.1f} M | "
            + (_rates(conditions.values()) or "not measured")
            + (f" | {pitch:.2f} |" if pitch is not None else " | — |")
            + f" {_tracking(kept)} |"
        )
    return "\n".join(rows)


def anymal_sac() -> str:
    """The rows of ANYmal C's SAC table: each run's rate and SAC's env steps, its step-0
    evaluation's tracking (speed, yaw rate) and its training evaluations' best of each (with
    their env steps), and the kept policy's env steps (`_kept_steps`): step 0 stays where no
    evaluation beats it in both."""
    runs = _campaign()
    rows = []
    for name, change in labels.ANYMAL_SAC.items():
        run = runs[name]
        first, *trained = run["evaluations"]
        best = {key: min(trained, key=lambda e: e[key]) for key in ("speed_rms", "yaw_rate_rms")}
        search = f"{run['gait_search']['seconds']} s" if "gait_search" in run else "— (given)"
        rows.append(
            f"| `{name}` | {change} | {search} |"
            f" {run['env_steps_per_s'] / 1e3:.1f} k, {trained[-1]['env_steps'] / 1e6:.1f} M |"
            f" {first['speed_rms']:.3f}, {first['yaw_rate_rms']:.3f} | "
            + ", ".join(f"{e[key]:.3f} ({e['env_steps'] / 1e6:.1f} M)" for key, e in best.items())
            + f" | {_kept_steps(run)} |"
        )
    return "\n".join(rows)


def _kept_steps(run: dict) -> str:
    """The env steps behind a run's kept policy (a run that only trained: its training's best)."""
    if run["kept"]:
        return f"{run['kept']['policy_env_steps'] / 1e6:.1f} M"
    return f"{run['best_of_run'] / 1e6:.1f} M (training's best, not evaluated)"


def no_preset() -> str:
    """The rows of the robot-without-a-preset table: each run's training rate (its first window
    of evaluations and the whole run) and, where evaluated, its kept policy."""
    runs = _campaign()
    rows = []
    for name, loads in labels.NO_PRESET.items():
        run, kept = runs[name], runs[name]["kept"]
        physics = run.get("solver_probe", "the preset's")
        first = run["evaluations"][1]["env_steps_per_s"] / 1e3
        policy = "not evaluated | — | —"
        if kept:
            policy = (
                f"{kept['policy_env_steps'] / 1e6:.1f} M | {_rates(run['robustness'].values())} |"
                f" {_tracking(kept)}"
            )
        whole = run["env_steps_per_s"] / 1e3
        rate = f"{first:.1f} k / {whole:.1f} k"
        rows.append(f"| `{name}` | {loads} | {physics} | {rate} | {policy} |")
    return "\n".join(rows)


ENGINES = ("MJX (JAX)", "C MuJoCo", "C MuJoCo, ONNX policy")
# NAME_engines.json -> (the policy, the flags every engine runs it with)
ENGINE_RUNS = {  # Go1's policy closes the drive's loops as it was trained (its config); Go2's not
    "unitree_go1_command": ("unitree_go1_command", ()),
    "unitree_go2_command": ("unitree_go2_command", ()),
    "anybotics_anymal_c_command": ("anybotics_anymal_c_command", ()),
}
# the schedule of a policy whose ranges SCHEDULE leaves (ANYmal C: 0.8 m/s, 0.4 rad/s)
SCHEDULES = {"anybotics_anymal_c_command": "0.4,0@5;0.8,0@5;0.5,0.3@5;0,0@5"}


def engines() -> str:
    """The rows of the sim-to-sim table: each command policy on SCHEDULE in each engine."""
    rows = []
    for name in ENGINE_RUNS:
        record = _load(f"{name}_engines.json")
        for label in ENGINES:
            e = record["engines"][label]
            rows.append(
                f"| `{name}` | {label} | {e['success_rate'] * e['num_episodes']:.0f} /"
                f" {e['num_episodes']} | {e['speed_tracking_rms']:.3f} |"
                f" {e['yaw_rate_tracking_rms']:.3f} | {e['mean_max_abs_pitch_error']:.3f} |"
                f" {e['mean_max_abs_roll']:.3f} |"
            )
    return "\n".join(rows)


SCHEDULE = "0.5,0@5;1.0,0@5;0.6,0.4@5;0,0@5"
FIGURE_POLICIES = {
    "Go1": "unitree_go1_command",
    "Go2": "unitree_go2_command",
    "ANYmal C": "anybotics_anymal_c_command",
}


def figure() -> None:
    from quadcos.viz import plots

    traces = {}
    with tempfile.TemporaryDirectory() as scratch:
        for label, name in FIGURE_POLICIES.items():
            trace = Path(scratch) / f"{name}.json"
            subprocess.run(
                [sys.executable, "-m", "quadcos.evaluate", f"--policy={POLICIES / name}",
                 f"--commands={SCHEDULES.get(name, SCHEDULE)}", "--num_envs=8", "--seconds=20",
                 "--no_progress",
                 f"--out={Path(scratch) / 'eval.json'}", f"--trace={trace}"],
                check=True,
            )
            traces[label] = plots.load_trace(trace)
    plots.plot_command_tracking(traces, path=HERE.parent.parent / "docs" / "command_tracking.png")


def blocks() -> tuple[str, ...]:
    """Every table's rows, in README.md's order."""
    return (
        table(),
        *map(seeds, (
            labels.PRESET, labels.ATTITUDE, labels.SEARCH_ATTITUDE, labels.TRACKED,
            labels.TRACK_ATTITUDE, labels.TRACK_ATTITUDE8, labels.SEARCH_TRACK_ATTITUDE8,
            labels.SEARCH_TRACK_ATTITUDE16, labels.SEARCH_TRACK_CONDITIONS16,
            labels.CONDITIONS16_UPDATES2, labels.CONDITIONS16_EVAL20, labels.PRESET_CONDITIONS,
            labels.LATENCY_LEVERS, labels.PRIVILEGED,
        )),
        anymal_sac(), no_preset(), gain(), campaign(), anymal(), sac_levers(),
        sac_levers(labels.GO1_LEVERS, gait=True), versus_gait(), against_gait(),
        engines(), levers(),
    )


def check() -> list[str]:
    """Where README.md's tables differ from the records': "lacks: ROW" for each generated row
    it lacks, "has: ROW" for each row under the header of a generated table (the block that
    makes most of its rows) that this block does not make; none where its tables are the
    records'."""
    text = (HERE / "README.md").read_text()
    lines = set(text.splitlines())
    made = [block.splitlines() for block in blocks() if block]
    stale = [f"lacks: {line}" for block in made for line in block if line not in lines]
    for table_text in re.split(r"\n(?!\|)", text):  # runs of consecutive "|" lines
        rows = [line for line in table_text.splitlines() if line.startswith("|")][2:]  # no header
        block = set(max(made, key=lambda block: len(set(block).intersection(rows)), default=[]))
        if block.intersection(rows):
            stale += [f"has: {row}" for row in rows if row not in block]
    return stale


if __name__ == "__main__":
    if sys.argv[1:] == ["--check"]:
        stale = check()
        print("\n".join(f"README.md {line}" for line in stale) or "README.md: tables current")
        sys.exit(1 if stale else 0)
    if sys.argv[1:] == ["--figure"]:
        figure()
    else:
        print("\n\n".join(block for block in blocks() if block))
