"""A from-scratch run's trainer compiled during its gait search (`quadcos.training.ahead`; the
run that uses it end to end: tests/test_gait_search.py), and a search that eats the run's time
budget warned of."""

import logging
import threading
import time

import pytest

from quadcos import train
from quadcos.training import ahead, session


@pytest.fixture(autouse=True)
def cpu_as_an_accelerator(monkeypatch):
    """The tests' CPU taken as a GPU would be, so that the compilation overlaps the search."""
    monkeypatch.setattr(ahead, "PLATFORMS", (*ahead.PLATFORMS, "cpu"))


def _config(**overrides: str):
    flags = {"env.action_centre": "search", "env.impl": "jax", **overrides}
    return train.build_config(train.PRESETS["smoke"], flags)


@pytest.mark.parametrize(
    "overrides, applies",
    [
        ({}, True),  # the tests' compilation cache is on
        ({"sac.gait_search.compile_trainer": False}, False),
        ({"env.action_centre": "trot"}, False),  # no search to overlap
        ({"env.impl": "warp"}, False),  # MJX-Warp (here: not installed, the env says so)
        ({"sac.num_devices": 1}, True),
    ],
)
def test_a_searching_run_on_mjx_jax_compiles_its_trainer_during_the_search(overrides, applies):
    assert ahead.applies(_config(**overrides)) is applies


def test_not_on_a_cpu(monkeypatch):
    monkeypatch.setattr(ahead, "PLATFORMS", ("gpu", "cuda", "rocm", "tpu"))
    assert not ahead.applies(_config())


def test_the_trainer_compiles_on_a_placeholder_gait_beside_the_search_and_is_waited_for():
    built, searched = [], threading.Event()

    def build_envs(env_config):
        built.append(env_config.action_centre)
        assert searched.wait(10)  # runs while the body (the search) runs
        raise RuntimeError("no envs in this test")

    with ahead.during_search(_config(), build_envs):
        searched.set()
    assert built == [ahead.PLACEHOLDER_CENTRE]  # the thread ran, and was joined on leaving


def test_a_search_that_raises_waits_for_the_thread():
    def build_envs(env_config):
        time.sleep(0.5)  # still compiling when the search is interrupted
        raise RuntimeError("no envs in this test")

    with pytest.raises(KeyboardInterrupt), ahead.during_search(_config(), build_envs):
        raise KeyboardInterrupt
    assert "quadcos-compile-during-search" not in [t.name for t in threading.enumerate()]


def test_a_failed_compilation_is_one_warning_and_the_run_goes_on(caplog):
    def build_envs(env_config):
        raise RuntimeError("boom")

    with (
        caplog.at_level(logging.WARNING, logger=ahead.__name__),
        ahead.during_search(_config(), build_envs),
    ):
        pass
    (record,) = caplog.records
    assert "RuntimeError: boom" in record.getMessage()
    assert "the run compiles it after the search" in record.getMessage()


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
