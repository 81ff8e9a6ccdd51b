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


def test_warp_buffers_scale_with_the_batch():
    config = env_lib.default_config()
    config.warp.max_envs = 4096
    assert backends.warp_sizes(config) == {"naconmax": 4096 * 8, "njmax": 64}


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
