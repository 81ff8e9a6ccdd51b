"""A run in two phases (`sac.at_actor_start`): the switch's words, the state carried over, and a
smoke run whose second phase goes on from its first one's state under the new settings."""

import json

import jax
import jax.numpy as jnp
import optax
import pytest

from quadcos import training
from quadcos._util.cli import UsageError
from quadcos.training import phases
from quadcos.training.checks import ConfigError
from quadcos.training.presets import PRESETS, build_config

SWITCH = "env.reward.forward=2.0, sac.max_grad_norm=1.0 sac.learning_rate.critic=1e-4"


def test_the_switch_reads_words_apart_by_spaces_or_commas_and_refuses_what_changes_shapes():
    assert phases.parse(SWITCH) == {
        "env.reward.forward": 2.0,
        "sac.max_grad_norm": 1.0,
        "sac.learning_rate.critic": 1e-4,
    }
    assert phases.parse("  ") == {}
    for text, message in [
        ("sac.num_envs=8", "'sac.num_envs' cannot change"),
        ("sac.hidden_sizes.q=(8,8)", "'sac.hidden_sizes.q' cannot change"),
        ("env.reward.forward", "is not KEY=VALUE"),
    ]:
        with pytest.raises(ValueError, match=message):
            phases.parse(text)


def test_the_second_phase_config_applies_the_switch_once_and_the_first_settings_are_kept():
    config = build_config(
        PRESETS["smoke"], {"sac.actor_warmup_steps": 100, "sac.at_actor_start": SWITCH}
    )
    second = phases.second(config)
    assert second.env.reward.forward == 2.0 and second.sac.max_grad_norm == 1.0
    assert second.sac.learning_rate.critic == 1e-4 and second.sac.at_actor_start == ""
    assert config.env.reward.forward != 2.0  # the first phase's config is left as it was
    assert phases.first_settings(config) == {
        "env.reward.forward": config.env.reward.forward,
        "sac.max_grad_norm": None,
        "sac.learning_rate.critic": config.sac.learning_rate.critic,
    }
    # smoke: 4 envs, a prefill of 256 env steps; 100 critic updates, one per step of the 4 envs
    assert phases.switch_step(config.sac) == 256 + 100 * 4
    with pytest.raises(UsageError, match="env.reward.forward"):
        build_config(
            PRESETS["smoke"],
            {"sac.actor_warmup_steps": 100, "sac.at_actor_start": "env.reward.forward=fast"},
        )


def test_a_state_is_carried_into_an_optimiser_that_clips_and_refused_where_shapes_differ():
    params = {"w": jnp.ones((3, 2)), "b": jnp.zeros(2)}
    adam, clipped = optax.adam(1e-3), optax.chain(optax.clip_by_global_norm(1.0), optax.adam(1e-3))
    state = {"params": params, "opt": adam.init(params), "steps": jnp.int32(7)}
    template = jax.eval_shape(lambda: {**state, "opt": clipped.init(params)})
    carried = phases.carried(state, template)
    assert jax.tree.structure(carried) == jax.tree.structure(template)
    assert int(carried["steps"]) == 7 and jnp.array_equal(carried["params"]["w"], params["w"])
    _, updated = clipped.update(params, carried["opt"], params)  # the clipping optimiser takes it
    assert int(updated[1][0].count) == 1
    wider = jax.eval_shape(lambda: {**state, "params": {"w": jnp.ones((3, 3)), "b": jnp.zeros(2)}})
    with pytest.raises(ConfigError, match="changes the training state's arrays"):
        phases.carried(state, wider)


@pytest.mark.slow
def test_a_two_phase_run_goes_on_from_its_first_phase_under_the_second_settings(tmp_path):
    config = build_config(
        PRESETS["smoke"],
        {"sac.actor_warmup_steps": 100, "sac.at_actor_start": SWITCH, "sac.seed": 3},
    )
    result = training.run(config, tmp_path / "run", progress=False)
    # smoke's chunks of 128 env steps: the first phase ends at the boundary at or past 656
    assert [row["step"] for row in result.history] == [0, 512, 768, 1024]
    # one run's updates: (1024 - 256) / 4 steps of the envs, one update each, none taken twice
    assert int(result.state.gradient_steps) == 192 and result.env_steps == 1024
    assert result.trainer.config.max_grad_norm == 1.0 and result.trainer.config.at_actor_start == ""
    saved = json.loads((tmp_path / "run" / "config.json").read_text())
    assert saved["config"]["learning_rate"]["critic"] == 1e-4
    assert saved["config"]["num_timesteps"] == 1024
    assert saved["run_info"]["env"]["reward"]["forward"] == 2.0
    assert saved["run_info"]["first_phase"] == {
        "until_step": 768,
        "env.reward.forward": 150.0,
        "sac.max_grad_norm": None,
        "sac.learning_rate.critic": 3e-4,
    }
    rows = [json.loads(line) for line in (tmp_path / "run" / "metrics.jsonl").open()]
    assert [row["step"] for row in rows] == [0, 512, 768, 1024]
    # the replay holds the first phase's transitions and the second's: every one of the run's
    assert result.trainer.replay_size(result.state) == 1024
