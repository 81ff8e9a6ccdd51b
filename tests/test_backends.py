"""Choosing the MJX implementation: JAX on the CPU, Warp only where it can run."""

import ml_collections
import pytest

from quadcos import env as env_lib
from quadcos.env import backends


def test_auto_is_jax_on_the_cpu():
    assert backends.resolve_impl("auto") == "jax"
    assert backends.resolve_impl("jax") == "jax"


def test_unknown_impl_is_named():
    with pytest.raises(ValueError, match="unknown impl 'cuda'; known: auto, jax, warp"):
        backends.resolve_impl("cuda")


def test_warp_without_warp_lang_says_how_to_install(monkeypatch):
    monkeypatch.setattr(backends, "warp_installed", lambda: False)
    with pytest.raises(ValueError, match=r"pip install 'quadcos\[warp\]'"):
        backends.resolve_impl("warp")
    assert backends.resolve_impl("auto") == "jax"


def test_warp_buffers_scale_with_the_batch_and_the_robots_contacts():
    config = env_lib.default_config()
    config.warp.max_envs = 4096
    paper = env_lib.make_env("flat", impl="jax").mj_model
    assert backends.warp_sizes(config, paper) == {"naconmax": 4096 * 8, "njmax": 64}
    # Condim-6 feet under a pyramidal cone: 10 rows a contact, beyond the paper robot's 64.
    model = env_lib.make_env("flat", robot="quad12", impl="jax").mj_model
    model.geom_condim[:] = 6
    model.opt.cone = 0
    rows = backends.constraint_rows(model, 8)
    assert rows == 8 * 10 + int(model.jnt_limited.sum()) and rows > 64
    assert backends.warp_sizes(config, model)["njmax"] == rows
    config.warp.constraints_per_env = 40
    assert backends.warp_sizes(config, model)["njmax"] == 40


def test_a_heightfield_gets_rows_for_the_contacts_it_makes():
    plane = env_lib.make_env("flat", robot="quad12", impl="jax").mj_model
    ramp = env_lib.make_env("slope5", robot="quad12", impl="jax").mj_model
    limited = int(ramp.jnt_limited.sum())
    per_contact = 6  # quad12: condim-6 feet, elliptic cones
    assert backends.constraint_rows(plane, 8) == 8 * per_contact + limited
    assert backends.constraint_rows(ramp, 8) == backends.HFIELD_CONTACTS * per_contact + limited
    assert backends.constraint_rows(ramp, 20) == 20 * per_contact + limited
    # The paper's robot keeps the 64 rows its results were measured with.
    paper = env_lib.make_env("slope5", impl="jax").mj_model
    assert backends.warp_sizes(env_lib.default_config(), paper)["njmax"] == 64


@pytest.mark.parametrize("key, value", [("max_envs", 0), ("contacts_per_env", -1)])
def test_bad_warp_sizes_are_refused(key, value):
    config = env_lib.default_config()
    config.warp[key] = value
    with pytest.raises(ValueError, match=f"warp.{key}"):
        env_lib.validate_config(config)


def test_survival_min_speed_is_validated():
    config = env_lib.default_config()
    config.survival_min_speed = float("nan")
    with pytest.raises(ValueError, match="survival_min_speed"):
        env_lib.validate_config(ml_collections.ConfigDict(config))
