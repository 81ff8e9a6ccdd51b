"""The result records (results/*.json) and the tables of README.md and docs/ generated from them:
`python -m quadcos.results --check` passes on the repository and fails on a page whose number
differs from its record; a record written by `record` renders back its sources' numbers."""

import json
import os
import pathlib
import shutil

import numpy as np
import pytest

from quadcos import results

ROOT = pathlib.Path(__file__).resolve().parent.parent


def _copy(tmp_path: pathlib.Path) -> pathlib.Path:
    """The pages and records of the repository, copied to `tmp_path`."""
    for name in ("README.md", "docs", "results"):
        source = ROOT / name
        if source.is_dir():
            shutil.copytree(source, tmp_path / name)
        else:
            shutil.copy(source, tmp_path / name)
    for readme in (ROOT / "experiments").glob("*/README.md"):  # pages too (results.PAGES)
        target = tmp_path / readme.relative_to(ROOT)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(readme, target)
    return tmp_path


def test_the_pages_agree_with_their_records(capsys):
    assert results.main(["--root", str(ROOT), "--check"]) == 0, capsys.readouterr().out


def _commands_script(monkeypatch, name: str):
    """experiments/commands/NAME.py as a module, the scripts beside it importable (as when run)."""
    import importlib.util

    monkeypatch.syspath_prepend(str(ROOT / "experiments/commands"))
    spec = importlib.util.spec_from_file_location(name, ROOT / f"experiments/commands/{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _commands_table(monkeypatch):
    return _commands_script(monkeypatch, "table")


def test_the_commanded_gait_page_agrees_with_its_records(monkeypatch):
    """experiments/commands/README.md's tables are table.py's rows of the JSONs beside it."""
    assert _commands_table(monkeypatch).check() == []


def test_the_page_check_names_missing_and_stray_rows(monkeypatch, tmp_path):
    table = _commands_table(monkeypatch)
    monkeypatch.setattr(table, "HERE", tmp_path)
    monkeypatch.setattr(table, "blocks", lambda: ("| `a` | 1 |\n| `b` | 2 |", "| `e` | 5 |"))
    page = "text\n\n| run | x |\n|---|---|\n| `a` | 1 |\n| `c` | 3 |\n| `e` | 5 |\n\n"
    page += "| other | y |\n|---|---|\n| `d` | 4 |\n"  # no generated row: not a generated table
    (tmp_path / "README.md").write_text(page)
    # `e` is generated, but by another table's block
    assert table.check() == ["lacks: | `b` | 2 |", "has: | `c` | 3 |", "has: | `e` | 5 |"]


def test_every_table_marker_in_the_pages_has_a_record():
    layout = results.load_layout(ROOT)
    names = {
        match["name"]
        for page in results.pages(ROOT)
        for match in results.MARKER.finditer(page.read_text())
    }
    assert {"readme", "paper", "bench_h100"} <= names
    assert names == set(layout), set(layout) ^ names


def test_a_changed_number_in_a_page_fails_the_check(tmp_path, capsys):
    root = _copy(tmp_path)
    page = root / "docs" / "benchmarks.md"
    text = page.read_text()
    table = text[text.index("<!-- results:bench_h100 -->") :]
    row = next(line for line in table.splitlines() if line.startswith("| flat | warp |"))
    changed = row.replace(" k |", "1 k |", 1)
    assert changed != row
    page.write_text(text.replace(row, changed, 1))
    assert results.main(["--root", str(root), "--check"]) == 1
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and out[0].startswith("docs/benchmarks.md: results:bench_h100 differs")
    assert results.main(["--root", str(root)]) == 0  # rendering puts the record's number back
    assert page.read_text() == text


def test_a_marker_without_a_table_and_a_changed_record_fail_the_check(tmp_path, capsys):
    root = _copy(tmp_path)
    with open(root / "docs" / "results.md", "a") as page:
        page.write("\n<!-- results:no_such_table -->\n<!-- /results:no_such_table -->\n")
    record = json.loads((root / "results" / "flat.json").read_text())
    record["numbers"]["eval_flat.success_rate"] = 0.5
    (root / "results" / "flat.json").write_text(json.dumps(record))
    assert results.main(["--root", str(root), "--check"]) == 1
    out = capsys.readouterr().out
    assert "docs/results.md: results:no_such_table has no table" in out
    assert "results/flat.json: its numbers are not those of its sources" in out


def test_a_record_round_trips_from_its_sources(tmp_path, capsys):
    evaluation = {
        "format": "quadcos.evaluation",
        "success_rate": 0.75,
        "mean_forward_speed": 0.5,
        "setup": {"num_envs": 4, "terrain": "flat"},
        "episodes": [{"success": True, "forward_speed": 0.5}] * 4,
    }
    sources = []
    for seed, speed in enumerate((0.5, 0.625)):
        path = tmp_path / f"eval_s{seed}.json"
        path.write_text(json.dumps({**evaluation, "mean_forward_speed": speed}))
        sources.append(str(path))
    argv = ["--root", str(tmp_path), "record", "--name", "toy", "--claim", "a toy claim"]
    argv += ["--command", "python -m quadcos.evaluate --out=eval.json", "--device", "CPU"]
    assert results.main([*argv, "--commit", "0" * 40, *sources]) == 0
    record = json.loads((tmp_path / "results" / "toy.json").read_text())
    assert record["numbers"] == {
        "eval_s0.success_rate": 0.75,
        "eval_s0.mean_forward_speed": 0.5,
        "eval_s0.setup.num_envs": 4,
        "eval_s1.success_rate": 0.75,
        "eval_s1.mean_forward_speed": 0.625,
        "eval_s1.setup.num_envs": 4,
    }
    assert all("episodes" not in source["summary"] for source in record["sources"])
    assert record["sources"][0]["path"] == sources[0] and record["device"] == "CPU"
    records = results.load_records(tmp_path)
    spec = {"text": "{toy:min *.mean_forward_speed|.3f}–{toy:max *.mean_forward_speed|.3f} "
                    "({toy:count *.success_rate} seeds, {toy:eval_s1.success_rate|.0f%})"}
    assert results.render(spec, records) == "0.500–0.625 (2 seeds, 75 %)"
    assert results.render({"text": "{toy:count *.missing} met"}, records) == "0 met"
    with pytest.raises(ValueError, match="no number matches"):
        results.render({"text": "{toy:min *.missing}"}, records)


_RECORD = ["--claim", "c", "--command", "c", "--device", "d", "--commit", "x"]


@pytest.mark.parametrize(
    "argv, message",
    [
        (["record", "--name", "bad name", *_RECORD, "a.json"], "record name"),
        (["record", "--name", "n", *_RECORD, "missing.json"], "not a readable JSON"),
        (["record", "--name", "n"], "required"),
    ],
)
def test_bad_arguments_are_one_line_and_exit_2(tmp_path, capsys, argv, message):
    assert results.main(["--root", str(tmp_path), *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


def test_a_template_naming_a_missing_number_is_an_error():
    records = {"r": {"numbers": {"a": 1.0}}}
    with pytest.raises(ValueError, match="no number 'r:b'"):
        results.fill("{r:b}", records)
    with pytest.raises(ValueError, match="no record 'q'"):
        results.fill("{q:a}", records)
    assert results.fill("{r:a / 4|.2f} {r:a|.1fk}", records) == "0.25 0.0 k"


def test_the_benchmarks_page_stays_short():
    assert len((ROOT / "docs" / "benchmarks.md").read_text().splitlines()) <= 250


def test_a_changed_value_in_prose_and_a_marker_at_a_line_start_fail_the_check(tmp_path, capsys):
    root = _copy(tmp_path)
    page = root / "docs" / "env.md"
    text = page.read_text()
    start = text.index("<!-- results:env.randomised_rate -->")
    end = text.index("<!-- /results:env.randomised_rate -->")
    body = text[start:end]
    changed = body.replace(" k against", "1 k against", 1)
    assert changed != body
    page.write_text(text[:start] + changed + text[end:])
    assert results.main(["--root", str(root), "--check"]) == 1
    assert "docs/env.md: results:env.randomised_rate differs" in capsys.readouterr().out
    page.write_text(text.replace("H100 with MJX-Warp, <!-- results:env.randomised_rate -->",
                                 "H100 with MJX-Warp,\n<!-- results:env.randomised_rate -->", 1))
    assert results.main(["--root", str(root), "--check"]) == 1
    assert "results:env.randomised_rate starts a line" in capsys.readouterr().out


def test_kept_values_rebuild_and_a_changed_source_fails_the_check(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # sources named as in a checkout: relative to its root
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    for folder, rate in (("a", 0.5), ("b", 0.75)):
        evaluation = {"success_rate": rate, "mean_forward_speed": 0.9, "setup": {"num_envs": 4}}
        (tmp_path / folder / "eval.json").write_text(json.dumps(evaluation))
    argv = ["--root", str(tmp_path), "record", "--name", "toy", "--claim", "c", "--command", "c"]
    argv += ["--device", "CPU", "--commit", "0" * 40, "--keep", "success_rate", "--"]
    argv += ["a/eval.json", "b/eval.json"]
    assert results.main(argv) == 0
    record = json.loads((tmp_path / "results" / "toy.json").read_text())
    assert record["numbers"] == {"a/eval.success_rate": 0.5, "b/eval.success_rate": 0.75}
    assert record["keep"] == ["success_rate"]
    assert record["sources"][0] == {"path": "a/eval.json", "summary": {"success_rate": 0.5}}
    (tmp_path / "results" / "tables.json").write_text("{}")
    assert results.main(["--root", str(tmp_path), "--check"]) == 0
    (tmp_path / "b" / "eval.json").write_text(json.dumps({"success_rate": 0.25}))
    assert results.main(["--root", str(tmp_path), "--check"]) == 1
    assert "results/toy.json: b/eval.json has changed" in capsys.readouterr().out
    assert results.main(["--root", str(tmp_path), "rebuild", "toy"]) == 0
    assert results.load_records(tmp_path)["toy"]["numbers"]["b/eval.success_rate"] == 0.25
    assert results.main(["--root", str(tmp_path), "--check"]) == 0


def test_every_record_rebuilds_from_its_sources_unchanged():
    for name, record in results.load_records(ROOT).items():
        if all((ROOT / source["path"]).is_file() for source in record["sources"]):
            assert results.rebuild(record, ROOT) == record, name


def test_the_time_to_targets_record_is_what_its_script_computes(tmp_path, monkeypatch):
    folder = ROOT / "experiments" / "any_slope"
    monkeypatch.syspath_prepend(str(folder))
    import time_to_targets  # noqa: PLC0415 — the experiment's script

    out = tmp_path / "time_to_targets.json"
    argv = ["--single", str(folder / "seeds_cold_warm.json"),
            "--population", *(str(folder / "population" / f"pop{name}")
                              for name in ("2_s0", "2_s2", "2_s4", "4_s0", "4_s4")),
            "--out", str(out)]
    assert time_to_targets.main(argv) == 0
    committed = (ROOT / "benchmarks" / "h200_time_to_targets.json").read_text()
    assert out.read_text() == committed
    cold_s0 = json.loads(committed)["rows"][0]  # 0.975 / 0.812, flat attitude 0.015
    assert cold_s0["seconds_to_targets"] is None and not time_to_targets.meets(cold_s0)
    met = dict(cold_s0, testset2026_worst=0.95)
    assert time_to_targets.meets(met)
    assert not time_to_targets.meets(dict(met, flat_max_attitude_rad=0.06))
    assert not time_to_targets.meets(dict(met, testset2026_mean=None))  # not evaluated: missed
    four = json.loads(committed)["rows"][-1]  # a population of four: its chosen member meets them
    assert four["num_devices"] == 4 and four["seconds_to_targets"] == four["seconds"]


def test_compact_rounds_to_six_digits_keeps_units_and_drops_episodes(tmp_path, capsys):
    value = {"rate": 1195864.25, "speed": 0.123456789, "tiny": 1.23456789e-7, "steps": 6004736,
             "flag": True, "none": None, "episodes": [{"speed": 0.5}], "rows": [2.718281828]}
    small = results.compact(value)
    assert small == {"rate": 1195864.0, "speed": 0.123457, "tiny": 1.23457e-07, "steps": 6004736,
                     "flag": True, "none": None, "rows": [2.71828]}
    assert results.compact(small) == small  # idempotent: a record of a compacted source agrees
    indented = tmp_path / "eval.json"
    indented.write_text(json.dumps(value, indent=1) + "\n")
    one_line = tmp_path / "robustness.json"
    one_line.write_text(json.dumps(value, separators=(",", ":")))
    assert results.main(["compact", str(indented), str(one_line)]) == 0
    assert "2 files compacted" in capsys.readouterr().out
    assert json.loads(indented.read_text()) == small and indented.read_text().startswith('{\n "')
    assert "\n" not in one_line.read_text() and json.loads(one_line.read_text()) == small
    assert results.compacted_text(indented, indented.read_text()) is None  # no smaller: as is
    broken, fresh = tmp_path / "broken.json", tmp_path / "fresh.json"
    broken.write_text("{")
    fresh.write_text(json.dumps(value))
    assert results.main(["compact", str(fresh), str(broken)]) == 2
    assert "broken.json: not a readable JSON file" in capsys.readouterr().err
    assert json.loads(fresh.read_text()) == value  # nothing written where one input is bad


def test_check_outside_a_repository_names_the_root_and_says_how(tmp_path, capsys):
    assert results.main(["--root", str(tmp_path), "--check"]) == 2
    assert f"no results/ under {tmp_path}" in capsys.readouterr().err
    assert results.main(["--root", str(ROOT), "--check"]) == 0
    assert "every page agrees" in capsys.readouterr().out


def test_the_attitude_scored_finalists_are_the_ones_the_commands_page_names(monkeypatch):
    """experiments/commands/README.md ("Gaits chosen by their tracking"): with
    `sac.gait_search.track_attitude` 0.10 the logged finalists of Go1's three `tracked` runs
    give way to seed 0's first, seed 1's second and seed 2's fourth."""
    track_gaits = _commands_script(monkeypatch, "track_gaits")
    runs = track_gaits.load_runs(ROOT / "experiments/commands/campaign.json")
    names = [f"go1cmd_tracked_s{seed}" for seed in range(3)]
    chosen = track_gaits.rescore(runs, names, 0.1)
    assert [(row["finalist"], row["ran_with"]) for row in chosen] == [(1, 2), (2, 4), (4, 1)]
    assert [row["speed_rms"] for row in chosen] == [0.12, 0.103, 0.094]
    assert chosen[2]["score"] > -1 > chosen[1]["score"] > chosen[0]["score"]  # only seed 2 within
    # without the attitude target the same lines give the finalists the runs kept
    assert [row["finalist"] for row in track_gaits.rescore(runs, names, 0.0)] == [2, 4, 1]


def test_the_campaign_record_packs_its_tables_and_loads_them_back_as_rows(monkeypatch, tmp_path):
    """experiments/commands/campaign.json holds each run's evaluations and conditions as rows under
    the record's columns; `load_runs` gives them back as dicts, `packed` refuses a key it would
    lose, and a record written by `--into` from the committed one loads the same runs."""
    import subprocess
    import sys

    monkeypatch.syspath_prepend(str(ROOT / "experiments/commands"))
    import training_summary

    record = ROOT / "experiments/commands/campaign.json"
    runs = training_summary.load_runs(record)
    evaluation = runs["anymalcmd_presetalone_s0"]["evaluations"][1]
    assert evaluation["env_steps"] == 2113536 and evaluation["worst_cell"] == "latency_40_ms/speed"
    assert "falls_above_step0" not in evaluation  # a null column is no key
    assert evaluation["critic_loss"] > 0 and evaluation["alpha"] > 0  # the learner's chunk
    assert "critic_loss" not in runs["anymalcmd_presetalone_s0"]["evaluations"][0]  # step 0: none
    nominal = runs["anymalcmd_presetalone_s0"]["robustness"]["nominal"]
    assert nominal["success_rate"] == 1.0 and set(nominal) == set(training_summary.KEYS[:5])
    run = runs["anymalcmd_presetalone_s0"]
    assert training_summary.unpacked(training_summary.packed(run)) == run
    with pytest.raises(ValueError, match="evaluations: \\['novel'\\]"):
        training_summary.packed({"evaluations": [{"env_steps": 0, "novel": 1.0}]})
    out = subprocess.run(
        [sys.executable, str(ROOT / "experiments/commands/training_summary.py"), "--into",
         str(record)], capture_output=True, text=True, check=True,
    ).stdout
    (tmp_path / "again.json").write_text(out)
    assert training_summary.load_runs(tmp_path / "again.json") == runs


def test_the_figure_of_sac_against_its_gait_plots_the_recorded_ratios(tmp_path):
    """`training_summary.py --figure PNG RUN...` plots each named run's recorded worst-cell ratio
    to step 0 and its critic's loss against env steps (the step-0 row, which has neither, left
    out); a run campaign.json lacks is refused by name, with nothing written."""
    import subprocess
    import sys

    from quadcos.viz import plots

    rows = [
        {"env_steps": 0},
        {"env_steps": 2_000_000, "to_step0": 1.02, "critic_loss": 0.7},
        {"env_steps": 4_000_000, "to_step0": 0.97, "critic_loss": 1.5},
    ]
    figure = plots.plot_against_gait({"a": rows, "b": rows[:2]}, path=tmp_path / "f.png")
    ratio_ax, critic_ax = figure.axes
    np.testing.assert_allclose(ratio_ax.lines[0].get_xdata(), [2.0, 4.0])
    np.testing.assert_allclose(ratio_ax.lines[0].get_ydata(), [1.02, 0.97])
    np.testing.assert_allclose(critic_ax.lines[1].get_ydata(), [0.7])
    assert ratio_ax.get_yscale() == "log" and critic_ax.get_yscale() == "linear"
    assert (tmp_path / "f.png").stat().st_size > 1000
    script = str(ROOT / "experiments/commands/training_summary.py")
    refused = subprocess.run(
        [sys.executable, script, "--figure", str(tmp_path / "g.png"), "no_such_run"],
        capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert refused.returncode == 1 and "no_such_run" in refused.stderr
    assert not (tmp_path / "g.png").exists()


def test_an_evaluation_against_step_0_names_its_worst_cell_and_each_measure_worst(monkeypatch):
    """`_against_gait` reads a run's metrics as the gait rank does: the worst ratio of any
    tracking cell to step 0's, and the worst among the speed cells and among the yaw-rate cells,
    so that a record shows what SAC traded (speed lost, yaw rate gained)."""
    import json

    monkeypatch.syspath_prepend(str(ROOT / "experiments/commands"))
    import training_summary

    def row(step, speed, yaw_rate):
        cells = {"eval/fall_rate": 0.0, "eval/nominal/fall_rate": 0.0}
        for condition, scale in (("nominal", 1.0), ("latency_40_ms", 2.0)):
            cells[f"eval/{condition}/speed_tracking_rms"] = speed * scale
            cells[f"eval/{condition}/yaw_rate_tracking_rms"] = yaw_rate * scale
        return {"step": step, **cells}

    metrics = "\n".join(json.dumps(r) for r in (row(0, 0.1, 0.2), row(10, 0.11, 0.1)))
    against = training_summary._against_gait(metrics)
    assert list(against) == [10]
    assert against[10]["to_step0"] == pytest.approx(1.1)
    assert against[10]["speed_to_step0"] == pytest.approx(1.1)
    assert against[10]["yaw_rate_to_step0"] == pytest.approx(0.5)
    assert against[10]["worst_cell"] in ("nominal/speed", "latency_40_ms/speed")


def test_a_run_that_only_trained_records_the_step_of_its_best_policy(monkeypatch, tmp_path):
    """A run packed without its evaluation (`run_gpu.sh train wait pack`) still says which policy
    its training kept: `best_of_run` from policy_best/policy.json, read from the folder and from
    the pack alike, and ANYmal C's table names it as the training's best, not evaluated."""
    import json
    import tarfile

    monkeypatch.syspath_prepend(str(ROOT / "experiments/commands"))
    import table
    import training_summary

    run = tmp_path / "runs" / "anymal_only_trained_s0"
    (run / "policy_best").mkdir(parents=True)
    (run / "anymal_only_trained_s0.log").write_text("quadcos.train: starting\n")
    best = {"config": {"best_of_run": {"step": 8052736, "eval/fall_rate": 0.0}}}
    (run / "policy_best" / "policy.json").write_text(json.dumps(best))
    with tarfile.open(tmp_path / "anymal_only_trained_s0.tgz", "w:gz") as tar:
        tar.add(run, arcname=run.name)
    for path in (run, tmp_path / "anymal_only_trained_s0.tgz"):
        summary = training_summary.summary(path)
        assert summary["best_of_run"] == 8052736 and summary["kept"] is None
    assert table._kept_steps(summary) == "8.1 M (training's best, not evaluated)"
    assert table._kept_steps({"kept": {"policy_env_steps": 0}}) == "0.0 M"
    (run / "policy_best" / "policy.json").unlink()  # a run that saved no best policy
    assert "best_of_run" not in training_summary.summary(run)


def test_a_resumed_run_records_the_flags_of_each_resume(monkeypatch, tmp_path):
    """A lever forked from another run's checkpoint (`--resume` in a copy of its folder) records
    the first command's flags and then each resume's, so that its lever shows in `argv`;
    --output_dir and --no_progress are left out."""
    import json

    monkeypatch.syspath_prepend(str(ROOT / "experiments/commands"))
    import training_summary

    run = tmp_path / "anymalfork_tent_s0"
    run.mkdir()
    (run / "anymalfork_tent_s0.log").write_text("quadcos.train: starting\n")
    first = ["--output_dir=/r/fork", "--seed=0", "--save_replay"]
    resume = ["--output_dir=/r/tent", "--no_progress", "--resume"]
    resume += ["--config.sac.target_entropy=-12"]
    info = {"argv": first, "resumed_argv": [resume]}
    (run / "config.json").write_text(json.dumps({"run_info": info}))
    assert training_summary.summary(run)["argv"] == [
        "--seed=0", "--save_replay", "--resume", "--config.sac.target_entropy=-12"
    ]
    (run / "config.json").write_text(json.dumps({"run_info": {"argv": first}}))
    assert training_summary.summary(run)["argv"] == ["--seed=0", "--save_replay"]


def test_kept_only_skips_the_evaluation_of_a_run_that_kept_its_gait(tmp_path):
    """`KEPT_ONLY=1 run_gpu.sh evaluate` evaluates nothing of a run whose training kept its
    step-0 gait (best_of_run step 0: its training evaluations already say how it does) and
    writes nothing for it; a bad RUN is still refused with exit 2."""
    import subprocess

    policy = tmp_path / "runs" / "anymal_gait_s0" / "policy_best"
    policy.mkdir(parents=True)
    (policy / "policy.json").write_text(json.dumps({"config": {"best_of_run": {"step": 0}}}))
    env = {**os.environ, "RUNS": str(tmp_path / "runs"), "OUT": str(tmp_path / "out"),
           "KEPT_ONLY": "1"}
    script = str(ROOT / "experiments/commands/run_gpu.sh")
    done = subprocess.run(["bash", script, "evaluate", "anymal_gait_s0@menagerie:x@0"],
                          env=env, capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "anymal_gait_s0 kept its step-0 gait: not evaluated" in done.stdout
    assert list((tmp_path / "out").iterdir()) == []
    bad = subprocess.run(["bash", script, "evaluate", "no_robot"], env=env, capture_output=True,
                         text=True, cwd=tmp_path)
    assert bad.returncode == 2 and "bad RUN 'no_robot'" in bad.stderr


def test_a_fork_refuses_a_lever_of_another_robot_or_seed_before_it_trains(tmp_path):
    """`run_gpu.sh fork FORK LEVER...` goes on from the fork's state, so each lever must be the
    fork's robot and seed: a lever of another seed is refused by name with exit 2, before the
    fork trains or anything is copied."""
    import subprocess

    env = {**os.environ, "RUNS": str(tmp_path / "runs"), "OUT": str(tmp_path / "out")}
    script = str(ROOT / "experiments/commands/run_gpu.sh")
    fork, lever = "f_s0@menagerie:x@0", "f_tent_s0@menagerie:x@1@--config.sac.target_entropy=-12"
    done = subprocess.run(["bash", script, "fork", fork, lever], env=env, capture_output=True,
                          text=True, cwd=tmp_path)
    assert done.returncode == 2
    assert "lever f_tent_s0: menagerie:x seed 1, not the fork's menagerie:x seed 0" in done.stderr
    assert list((tmp_path / "runs").iterdir()) == []


def test_phase_share_tells_a_value_that_follows_the_stride_from_one_that_does_not(monkeypatch):
    """tracking_windows.phase_share: ~1 for an action value repeating each stride, ~0 for one
    that drifts across strides or holds still."""
    tracking_windows = _commands_script(monkeypatch, "tracking_windows")
    steps = np.arange(2_000)
    phases = np.mod(steps * 0.7, 2 * np.pi)  # ~9 control steps a stride
    rng = np.random.default_rng(0)
    actions = np.stack(
        [
            0.4 * np.cos(phases) - 0.2 * np.sin(2 * phases) + 0.01 * rng.normal(size=steps.size),
            np.sin(steps / 300.0),  # slow, across strides
            np.full(steps.size, 0.3),  # constant
        ],
        axis=1,
    )
    share = tracking_windows.phase_share(actions, phases)
    assert share[0] > 0.99
    assert share[1] < 0.05
    assert share[2] == 0.0
