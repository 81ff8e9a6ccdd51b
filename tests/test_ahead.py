"""A from-scratch run's trainer built before its gait search and compiled during it
(`quadcos.training.ahead`; the run that uses it end to end: tests/test_gait_search.py), the
trainers kept for later runs of the same programs given the run's gait (`reuse`), and a search
that eats the run's time budget warned of."""

import jax
import ml_collections
import numpy as np
import pytest

from quadcos import train, training
from quadcos.env import quadruped
from quadcos.equations import oscillator
from quadcos.training import ahead, host, parallel, reuse, session


@pytest.fixture(autouse=True)
def cpu_as_an_accelerator(monkeypatch):
    """The tests' CPU taken as a GPU would be, so that the compilation overlaps the search."""
    monkeypatch.setattr(ahead, "PLATFORMS", (*ahead.PLATFORMS, "cpu"))


def _config(**overrides: str):
    flags = {"env.action_centre": "search", "env.impl": "jax", **overrides}
    return train.build_config(train.PRESETS["smoke"], flags)


@pytest.mark.parametrize(
    "overrides, resume, applies",
    [
        ({}, False, True),
        ({"sac.gait_search.compile_trainer": False}, False, False),
        ({"env.action_centre": "trot"}, False, False),  # no search to overlap
        ({}, True, False),  # a resumed run: its state comes from a checkpoint
        ({"sac.num_devices": 1}, False, True),
    ],
)
def test_a_fresh_searching_run_on_one_device_builds_its_trainer_first(overrides, resume, applies):
    assert ahead.applies(_config(**overrides), resume) is applies


def test_not_on_a_cpu(monkeypatch):
    monkeypatch.setattr(ahead, "PLATFORMS", ("gpu", "cuda", "rocm", "tpu"))
    assert not ahead.applies(_config())


def test_the_program_key_leaves_out_the_gait_a_search_sets():
    config = _config()
    searched = ml_collections.ConfigDict(config.env.to_dict())
    searched.action_centre = "0.38877,0.195895,0.50539,1.8099,-1.33169"
    searched.commands.reference_speed = 0.9
    assert reuse.program_key(searched, config.sac) == reuse.program_key(config.env, config.sac)
    searched.action_scale = 0.3  # a field the programs read
    assert reuse.program_key(searched, config.sac) != reuse.program_key(config.env, config.sac)


def test_on_several_devices_the_program_key_keeps_the_gait(monkeypatch):
    # (the initial state's program holds the gait as a constant there)
    monkeypatch.setattr(reuse.parallel, "make_layout", lambda n: parallel.Layout(mesh=object()))
    config = _config()
    searched = ml_collections.ConfigDict(config.env.to_dict())
    searched.action_centre = "0.38877,0.195895,0.50539,1.8099,-1.33169"
    assert reuse.program_key(searched, config.sac) != reuse.program_key(config.env, config.sac)


def test_an_env_with_a_searched_gait_is_the_env_built_for_it():
    config = _config(**{"env.commands.spec": "random", "env.commands.feed_forward": True})
    placeholder = ml_collections.ConfigDict(config.env.to_dict())
    placeholder.action_centre = ahead.PLACEHOLDER_CENTRE
    searched = ml_collections.ConfigDict(config.env.to_dict())
    searched.action_centre = "0.38877,0.195895,0.50539,1.8099,-1.33169"
    searched.commands.reference_speed, searched.commands.half_track = 0.9, 0.2
    base = quadruped.QuadrupedEnv(config.env.terrain, placeholder)
    env = base.with_gait_of(searched)
    built = quadruped.QuadrupedEnv(config.env.terrain, searched)
    assert env.config.to_dict() == built.config.to_dict()
    for name, value in built.gait.items():
        np.testing.assert_array_equal(env.gait[name], value)
    np.testing.assert_array_equal(
        env.action_centre, oscillator.action_centre(searched.action_centre, config.env.period_min)
    )
    assert env.commands.spec == built.commands.spec
    assert env.mj_model is base.mj_model and base.config.action_centre == ahead.PLACEHOLDER_CENTRE


@pytest.mark.parametrize(
    "max_seconds, searched_s, warned",
    [(0, 500.0, False), (300, 149.0, False), (300, 150.0, True), (300, 476.0, True)],
)
def test_a_search_that_takes_half_the_run_or_more_is_warned_of(max_seconds, searched_s, warned):
    message = session.search_overrun(max_seconds, searched_s)
    assert (message is not None) is warned
    if warned:
        assert f"ended {searched_s:.0f} s into the run's {max_seconds} s" in message
        assert f"leaving SAC {max(max_seconds - searched_s, 0):.0f} s" in message


def test_a_trainer_compiled_during_the_search_trains_as_one_built_after_it():
    # the run's trainer built before the search on a placeholder gait, then given the gait
    # found, against one built after the search (the smoke run's programs, as other tests')
    centre = "0.38877,0.195895,0.50539,1.8099,-1.33169"

    def find_gait(config):
        return {"action_centre": centre, "setup": {"wall_time_s": 0.0}}

    runs = {}
    for first in (True, False):
        flags = {"env.action_centre": "search", "sac.gait_search.compile_trainer": first}
        flags["sac.num_timesteps"] = 320  # the prefill and one chunk
        config = train.build_config(train.PRESETS["smoke"], flags)
        startup = host.StartUp()
        result = training.run(config, find_gait=find_gait, progress=False, startup=startup)
        runs[first] = result, startup
    (early, startup), (after, startup_after) = runs[True], runs[False]
    events = list(startup.seconds)
    assert events.index("trainer_traced") < events.index("gait_search") < events.index("envs_built")
    assert "trainer_traced" not in startup_after.seconds
    # traced before the search, and not again after it
    assert startup.compile["trainer_traced"]["lower_s"] > 0
    assert (
        startup.compile["programs_traced"]["lower_s"]
        == 0
        < startup_after.compile["programs_traced"]["lower_s"]
    )
    # both step through the gait found, and are the same run
    gait = early.state.env_state.info["gait"]["action_map"][0]
    period_min = config.env.period_min
    expected = oscillator.action_map(period_min, oscillator.action_centre(centre, period_min))
    np.testing.assert_allclose(gait, expected, rtol=1e-6)
    np.testing.assert_array_equal(gait, after.state.env_state.info["gait"]["action_map"][0])
    for mine, theirs in zip(
        jax.tree.leaves(early.state.policy_params), jax.tree.leaves(after.state.policy_params)
    ):
        np.testing.assert_array_equal(mine, theirs)
    assert early.env_steps == after.env_steps > 0
