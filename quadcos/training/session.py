"""A whole training run from one config: `run(config, run_dir)`.

What `python -m quadcos.train` does once its flags are a config, and what a library caller gets
the same way: Warp's contact buffer sized for the largest batch, the gait search of a
from-scratch run (`env.action_centre="search"`), the envs built, the run trained (or resumed) by
`loop.train` (in two phases where `sac.at_actor_start` names settings for the actor's start:
`quadcos.training.phases`), and the envs and trainer kept in a `reuse.Trainers` the caller
holds, for a later run of the same programs.
"""

import functools
import json
import logging
import os
import pathlib
from collections.abc import Callable
from typing import Any

import jax
import ml_collections

from quadcos import env as env_lib
from quadcos._util import files
from quadcos.env import solver_probe, warp_preload
from quadcos.equations import oscillator
from quadcos.training import ahead, host, loop, phases, reuse, sac
from quadcos.training.checks import ConfigError

SEARCH_FILE = "gait_search.json"
logger = logging.getLogger(__name__)

# config -> the search's result with "action_centre" (`quadcos.evaluation.gait_search.find_gait`:
# the search evaluates fixed gaits, a layer above training, so the caller hands it in).
GaitSearch = Callable[[ml_collections.ConfigDict], dict[str, Any]]


def search_envs(config: ml_collections.ConfigDict) -> int:
    """Robots the gait search steps at once (for sizing Warp's buffers)."""
    search = config.sac.gait_search
    return search.num_candidates * search.robots_per_candidate


def run(
    config: ml_collections.ConfigDict,
    run_dir: str | os.PathLike[str] | None = None,
    *,
    resume: bool = False,
    trainers: reuse.Trainers | None = None,
    find_gait: GaitSearch | None = None,
    progress: bool = True,
    progress_bar: bool = True,
    extra_run_info: dict[str, Any] | None = None,
    started_at: float | None = None,
    startup: host.StartUp | None = None,
) -> loop.TrainResult:
    """Trains the run `config` describes (`{"env", "sac"}`: `quadcos.training.presets.build_config`).

    Sets `config.env.warp.max_envs` to the largest batch of the run (training, evaluation, gait
    search). For a robot without a preset whose physics the config leaves to it, measures the
    cheapest stable physics (`quadcos.env.solver_probe`), logs it in one line and puts it in
    `config.env` (so config.json holds it: a resumed or evaluated run probes nothing). With
    `env.action_centre="search"`, first runs `find_gait` on the run's terrain and trains from
    the gait it found (in `config.env.action_centre`, and `run_dir`/gait_search.json), its envs
    and trainer built before it and their programs compiled meanwhile where
    `quadcos.training.ahead` applies. Otherwise builds the envs after it, or takes them and their
    compiled trainer from `trainers` when it holds a run of the same programs
    (`reuse.program_key`; given this run's gait: `reuse.with_gait`). Trains with `loop.train`
    (with `sac.at_actor_start`, to the actor's start and then on in the second phase's envs and
    trainer) and keeps the envs and trainers in `trainers`.

    Args:
      config: the run config; changed in place as above.
      run_dir: as for `loop.train` (None: nothing written).
      resume: continue the run in `run_dir` (`loop.train`).
      trainers: the envs and trainers of earlier runs, kept by the caller; None: build afresh.
      find_gait: the gait search (`quadcos.evaluation.gait_search.find_gait`); needed only with
        `env.action_centre="search"`.
      progress, progress_bar, started_at, startup: as for `loop.train`; `startup` is marked
        after the solver probe ("solver_probe"), the trainer traced before the search
        ("trainer_traced"), the gait search ("gait_search") and the envs ("envs_built").
      extra_run_info: stored in config.json's `run_info` beside the env config, the physics
        implementation, the robot's provenance, the gait search's wall time and the solver
        probe's measurements.

    Returns:
      `loop.train`'s result.

    Raises:
      ConfigError: a search centre without `find_gait`, or as `loop.train` raises it.
      Whatever `find_gait`, the env or `loop.train` raise (`loop.train`'s docstring).
    """
    run_dir = pathlib.Path(run_dir) if run_dir is not None else None
    startup = host.StartUp(started_at) if startup is None else startup
    config.env.warp.max_envs = max(
        config.env.warp.max_envs,
        config.sac.num_envs,
        config.sac.num_eval_envs,
        search_envs(config),
    )
    probed = _probe_physics(config.env)
    if probed is not None:
        startup.mark("solver_probe")
    _check_search(config, find_gait)
    key = reuse.program_key(config.env, config.sac)  # (without the gait: the same after a search)
    built = _built_before_search(config, key, resume, trainers, startup)
    search = _resolve_centre(config, run_dir, find_gait, startup)
    if search is not None:
        overrun = search_overrun(config.sac.max_seconds, startup.seconds["gait_search"])
        if overrun and started_at is not None:  # the search counts in the run's time
            logger.warning("%s", overrun)
    if built is not None:  # given the gait the search found (or this run's, for a kept trainer)
        env, eval_env, trainer = reuse.with_gait(*built, config.env)
    else:
        with warp_preload.deferred():  # Warp's modules compile while the trainer's programs do
            env, eval_env = _envs(config.env)
        trainer = None
    startup.mark("envs_built")
    run_info = {
        **(extra_run_info or {}),
        "impl": env.impl,
        "robot": env.robot.provenance(),
        **({"gait_search_s": search["setup"]["wall_time_s"]} if search else {}),
        **({"solver_probe": probed} if probed else {}),
    }
    # two phases: the first ends as the actor starts
    switch = phases.switch_step(config.sac) if config.sac.at_actor_start.strip() else None
    train = functools.partial(
        loop.train, run_dir=run_dir, progress=progress, progress_bar=progress_bar,
        started_at=started_at,
    )
    result = train(
        env, config.sac, eval_env=eval_env, resume=resume, startup=startup, trainer=trainer,
        until=switch, extra_run_info={"env": config.env.to_dict(), **run_info},
    )
    if trainers is not None:
        trainers.keep(key, env, eval_env, result.trainer)
    unswitched = switch is None or result.stopped_by_signal or result.env_steps < switch
    if unswitched or result.env_steps >= config.sac.num_timesteps:
        return result  # one phase, stopped before the switch (a signal, the time), or done
    return _second_phase(config, result, train, trainers, run_info)


def _second_phase(
    config: ml_collections.ConfigDict,
    first: loop.TrainResult,
    train: Callable[..., loop.TrainResult],
    trainers: reuse.Trainers | None,
    run_info: dict[str, Any],
) -> loop.TrainResult:
    """Trains the run `config` (whose `sac.at_actor_start` is set) on from its first phase's
    result `first` under the second phase's settings (`phases.second`), in envs and a trainer
    of those (kept in `trainers`)."""
    second = phases.second(config)
    logger.info(
        "env step %s: the actor starts; from now on %s", f"{first.env_steps:,}",
        config.sac.at_actor_start.strip(),
    )
    key = reuse.program_key(second.env, second.sac)
    kept = trainers.get(key, second.sac) if trainers is not None else None
    if kept is not None:
        env, eval_env, trainer = reuse.with_gait(*kept, second.env)
    else:
        env, eval_env = _envs(second.env)
        trainer = sac.SACTrainer(env, second.sac, eval_env=eval_env)
    result = train(
        env, second.sac, eval_env=eval_env, trainer=trainer,
        state=phases.carried(first.state, trainer.state_shapes),
        extra_run_info={
            "env": second.env.to_dict(),
            **run_info,
            "first_phase": {"until_step": first.env_steps, **phases.first_settings(config)},
        },
    )
    if trainers is not None:
        trainers.keep(key, env, eval_env, result.trainer)
    return result


def search_overrun(max_seconds: float, searched_s: float) -> str | None:
    """For a run with a time budget of `max_seconds` (0: none) whose gait search ended
    `searched_s` s after its start: a warning where the search took half the budget or more
    (SAC gets the rest), else None."""
    if not max_seconds or searched_s < max_seconds / 2:
        return None
    return (
        f"the gait search ended {searched_s:.0f} s into the run's {max_seconds:g} s"
        f" (sac.max_seconds), leaving SAC {max(max_seconds - searched_s, 0):.0f} s: give the run"
        " more time or the search fewer rounds or candidates (sac.gait_search.*)"
    )


def _probe_physics(env_config: ml_collections.ConfigDict) -> dict[str, Any] | None:
    """For an env config whose robot needs it (`solver_probe.needs_probe`): the probe's record,
    its choice written into `env_config`. Otherwise nothing (None)."""
    if not solver_probe.needs_probe(env_config):
        return None
    result = solver_probe.probe(env_config)
    logger.info("%s", result.message)
    solver_probe.apply(env_config, result)
    return result.record()


def _resolve_centre(
    config: ml_collections.ConfigDict,
    run_dir: pathlib.Path | None,
    find_gait: GaitSearch | None,
    startup: host.StartUp | None = None,
) -> dict[str, Any] | None:
    """For a run config whose action centre is "search" (and a `find_gait`: `_check_search`):
    runs `find_gait`, puts the gait found in `config.env.action_centre` and writes the search to
    `run_dir`/gait_search.json; marks `startup` (if any) at the search's end. Other configs:
    nothing (None)."""
    if config.env.action_centre != oscillator.SEARCH_CENTRE:
        return None
    search = find_gait(config)
    if startup is not None:
        startup.mark("gait_search")
    config.env.action_centre = search["action_centre"]
    # the feed-forward measured on the gait found
    for key in ("reference_speed", "half_track", "speed_map"):
        if key in search.get("feed_forward", {}):
            config.env.commands[key] = search["feed_forward"][key]
    if run_dir is not None:
        run_dir.mkdir(parents=True, exist_ok=True)
        files.atomic_write_text(run_dir / SEARCH_FILE, json.dumps(search, indent=2) + "\n")
    return search


def _built_before_search(
    config: ml_collections.ConfigDict,
    key: str,
    resume: bool,
    trainers: reuse.Trainers | None,
    startup: host.StartUp,
) -> tuple[Any, Any, Any] | None:
    """The envs and trainer kept in `trainers` for `key`, else (where `ahead.applies`) the run's
    own, built on a placeholder gait and compiling while the gait search runs (marks
    "trainer_traced"), else None."""
    if trainers is not None and jax.process_count() == 1:
        kept = trainers.get(key, config.sac)
        if kept is not None:
            return kept
    if not ahead.applies(config, resume):
        return None
    with warp_preload.deferred():  # Warp's modules compile while the trainer is traced
        built = ahead.trainer_first(config, _envs)
    startup.mark("trainer_traced")
    return built


def _check_search(config: ml_collections.ConfigDict, find_gait: GaitSearch | None) -> None:
    """Raises ConfigError where the run `config` searches but has no `find_gait`."""
    if config.env.action_centre == oscillator.SEARCH_CENTRE and find_gait is None:
        raise ConfigError(
            f'env.action_centre="{oscillator.SEARCH_CENTRE}" needs a gait search: pass'
            " find_gait=quadcos.evaluation.gait_search.find_gait"
        )


def _envs(env_config: ml_collections.ConfigDict) -> tuple[Any, Any]:
    """The training env and the evaluation env (the same unless robots spawn along the ground:
    evaluations start at the spawn point, as quadcos.evaluate's do; or unless evaluations take
    robustness conditions, `randomization.eval_conditions`)."""
    env = env_lib.QuadrupedEnv(env_config.terrain, ml_collections.ConfigDict(env_config.to_dict()))
    conditions = (
        env_config.randomization.eval_conditions if env_config.randomization.enabled else ""
    )
    if env_config.spawn_x_max <= 0 and not conditions:
        return env, env
    eval_config = ml_collections.ConfigDict(env_config.to_dict())
    eval_config.spawn_x_max = 0.0
    eval_config.randomization.conditions = conditions or env_config.randomization.conditions
    return env, env_lib.QuadrupedEnv(env_config.terrain, eval_config)
