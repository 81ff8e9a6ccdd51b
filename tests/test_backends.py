"""Choosing the MJX implementation: JAX on the CPU, Warp only where it can run."""

import contextlib
import logging
import sys
import threading
import time
import types

import ml_collections
import pytest

from quadcos import bench
from quadcos import env as env_lib
from quadcos import train
from quadcos._util import quiet
from quadcos.env import backends, warp_arena, warp_preload
from quadcos.robot import presets


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


def test_auto_on_a_gpu_without_warp_lang_runs_jax_and_says_so(monkeypatch, caplog):
    monkeypatch.setattr(backends, "cuda_available", lambda: True)
    monkeypatch.setattr(backends, "warp_installed", lambda: False)
    with caplog.at_level("WARNING", logger=backends.__name__):
        assert backends.resolve_impl("auto", gpu_physics="warp") == "jax"
    assert "warp-lang is not installed" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger=backends.__name__):
        assert backends.resolve_impl("auto", gpu_physics="jax") == "jax"  # its own choice
    assert caplog.text == ""


@pytest.fixture
def fake_warp(monkeypatch):
    """A stand-in `warp` module (warp-lang is absent on the CPU machines) as Warp before 1.1x:
    `config.quiet`, its module-load lines printed by default; QUADCOS_VERBOSE empty."""
    warp = types.ModuleType("warp")
    warp.config = types.SimpleNamespace(quiet=False)
    monkeypatch.setitem(sys.modules, "warp", warp)
    monkeypatch.setattr(backends, "warp_installed", lambda: True)
    monkeypatch.setenv(quiet.VERBOSE_ENV, "")  # restored after the test, whatever it sets
    return warp


def test_warp_is_quiet_by_default_and_verbose_keeps_its_lines(fake_warp, monkeypatch):
    assert backends.resolve_impl("warp") == "warp" and fake_warp.config.quiet
    quiet.quiet_warp(verbose=True)
    assert not fake_warp.config.quiet
    backends.resolve_impl("warp")  # the env's own call keeps the choice
    assert not fake_warp.config.quiet


def test_warp_with_log_levels_is_quiet_at_its_warning_level(fake_warp):
    """Warp 1.19 prints a module-load line at its info level (20) and ignores `config.quiet`."""
    fake_warp.LOG_INFO, fake_warp.LOG_WARNING = 20, 30
    fake_warp.config.log_level = fake_warp.LOG_INFO
    backends.resolve_impl("warp")
    assert fake_warp.config.log_level == fake_warp.LOG_WARNING
    quiet.quiet_warp(verbose=True)
    assert fake_warp.config.log_level == fake_warp.LOG_INFO


@pytest.mark.parametrize("verbose", [False, True])
def test_train_silences_warp_before_building_anything_unless_verbose(fake_warp, verbose, capsys):
    flags = ["--print_config", *(["--verbose"] if verbose else [])]
    assert train.main(flags) == 0  # returns before any env is built
    capsys.readouterr()
    assert fake_warp.config.quiet is not verbose


def test_the_bench_takes_verbose():
    assert bench._parser().parse_args(["--verbose"]).verbose  # noqa: SLF001
    assert not bench._parser().parse_args([]).verbose  # noqa: SLF001
    assert train.resolve(["--verbose"])[0].verbose and not train.resolve([])[0].verbose


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


def test_a_heightfield_gets_rows_for_the_contacts_it_makes(monkeypatch):
    plane = env_lib.make_env("flat", robot="quad12", impl="jax")
    ramp = env_lib.make_env("slope5", robot="quad12", impl="jax")
    limited = int(ramp.mj_model.jnt_limited.sum())
    per_contact = 6  # quad12: condim-6 feet, elliptic cones
    assert backends.constraint_rows(plane.mj_model, 8, 24) == 8 * per_contact + limited
    assert backends.constraint_rows(ramp.mj_model, 8, 24) == 24 * per_contact + limited
    assert backends.constraint_rows(ramp.mj_model, 30, 24) == 30 * per_contact + limited
    # The env's resolved config carries the robot preset's heightfield contacts ...
    assert ramp.config.warp.hfield_contacts == presets.HFIELD_CONTACTS
    assert backends.warp_sizes(ramp.config, ramp.mj_model)["njmax"] == (
        presets.HFIELD_CONTACTS * per_contact + limited
    )
    # ... unless the config gives its own.
    more = env_lib.make_env("slope5", robot="quad12", impl="jax", **{"warp.hfield_contacts": 30})
    assert backends.warp_sizes(more.config, more.mj_model)["njmax"] == 30 * per_contact + limited
    # The paper's robot keeps the 64 rows its results were measured with.
    paper = env_lib.make_env("slope5", impl="jax")
    assert backends.warp_sizes(paper.config, paper.mj_model)["njmax"] == 64
    assert presets.PRESETS["anybotics_anymal_c"].hfield_contacts == 24


@pytest.mark.parametrize(
    "key, value", [("max_envs", 0), ("contacts_per_env", -1), ("hfield_contacts", -2)]
)
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


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("warp.graph_mode", "graphs", "unknown warp.graph_mode 'graphs'; known: auto, warp,"),
        ("substep_unroll", 0, "substep_unroll must be a whole number >= 1; got 0"),
        ("warp.graph_mode", "jax", "warp.graph_mode 'jax' needs warp.graph_conditional=false"),
    ],
)
def test_bad_loop_and_graph_settings_are_named(key, value, message):
    config = env_lib.default_config()
    *parents, leaf = key.split(".")
    (config[parents[0]] if parents else config)[leaf] = value
    with pytest.raises(ValueError, match=message):
        env_lib.validate_config(config)


def test_xla_records_loops_and_runs_branches_side_by_side_only_with_warps_jax_graphs():
    import jax
    import jax.numpy as jnp

    warp = env_lib.default_config().warp
    assert backends.compiler_options("jax", warp) == {}
    assert backends.compiler_options("warp", warp) == {}  # graph_mode "auto": Warp's own graphs
    warp.graph_mode = "jax"
    options = backends.compiler_options("warp", warp)
    assert options["xla_gpu_command_buffer_scheduling_mode"] == "CONCURRENT"
    recorded = set(options["xla_gpu_enable_command_buffer"].split(","))
    assert {"WHILE", "FUSION", "CUSTOM_CALL"} <= recorded
    # Not branches: an MJX-Warp call under lax.cond in a conditional node hung a course run.
    assert "CONDITIONAL" not in recorded
    # Names and values XLA knows (a misspelt one fails to compile on any backend).
    compiled = jax.jit(jnp.sin, compiler_options=options).lower(jnp.ones(3)).compile()
    assert float(compiled(jnp.zeros(3))[0]) == 0.0


def test_an_arena_gives_a_call_the_same_blocks_every_time():
    blocks = iter(range(0x1000, 0x100000, 0x1000))
    requested = []

    def malloc(size):
        requested.append(size)
        return next(blocks)

    arena = warp_arena.Arena(malloc)
    first = [arena.allocate(size) for size in (256, 64, 0, 256)]
    assert len(set(first)) == 4 and requested == [256, 64, 0, 256]
    arena.deallocate(first[0], 256)  # freeing keeps the block
    arena.rewind()
    assert [arena.allocate(size) for size in (256, 64, 0, 256)] == first
    assert len(requested) == 4  # nothing new allocated
    arena.rewind()
    arena.allocate(256)
    grown = arena.allocate(128)  # outgrows its block: a new one, the old one kept
    assert grown not in first and requested[-1] == 128
    assert arena.nbytes == 256 + 128 + 0 + 256 + 64
    arena.rewind()
    assert [arena.allocate(size) for size in (256, 128)] == [first[0], grown]


def test_arena_wrapping_is_idempotent_and_keeps_the_name():
    def step(m, d):
        return m, d

    wrapped = warp_arena.with_arena(step)
    assert wrapped.__name__ == "step" and warp_arena.with_arena(wrapped) is wrapped


@pytest.mark.slow
def test_unrolled_substeps_step_the_robots_as_the_loop_does():
    import jax
    import jax.numpy as jnp
    import numpy as np

    looped = env_lib.make_env("flat", impl="jax", control_dt=0.01)  # 2 physics steps
    unrolled = env_lib.make_env("flat", impl="jax", control_dt=0.01, substep_unroll=2)
    state = jax.jit(looped.reset)(jax.random.PRNGKey(0))
    action = jnp.full(looped.action_size, 0.3)
    # Each step traced once: its text is read, then the same lowering compiled and run.
    lowered = [jax.jit(env.step).lower(state, action) for env in (looped, unrolled)]
    one, other = (steps.compile()(state, action) for steps in lowered)
    np.testing.assert_allclose(one.pipeline_state.qpos, other.pipeline_state.qpos, atol=1e-6)
    assert float(one.reward) == pytest.approx(float(other.reward), abs=1e-4)
    # the substep loop is the one while loop that unrolling removes (MJX's own loops remain)
    loops = [steps.as_text().count("stablehlo.while") for steps in lowered]
    assert loops[0] == loops[1] + 1


def _module(name):
    return types.SimpleNamespace(name=name)


def _kernel(name):
    return types.SimpleNamespace(module=_module(name))


def test_a_recorded_step_records_each_launched_module_and_runs_no_kernel(fake_warp):
    ran = []
    fake_warp.launch = fake_warp.launch_tiled = lambda *args, **kwargs: ran.append(args)
    fake_warp.capture_while = fake_warp.capture_if = lambda *args, **kwargs: ran.append(args)
    originals = {name: getattr(fake_warp, name) for name in ("launch", "capture_while")}

    def solver_iteration(**kwargs):  # a graph loop's body: once, with the loop's arguments
        fake_warp.launch(_kernel("solver"), 4, inputs=[kwargs["m"]])

    with warp_preload.launches_recorded(fake_warp) as launched:
        fake_warp.launch(_kernel("smooth"), 4096, inputs=[])
        fake_warp.launch(_kernel("smooth"), (2, 3), block_dim=0)  # the same module, Warp's 256
        fake_warp.launch(kernel=_kernel("equality"), dim=0)  # no work: Warp loads nothing
        fake_warp.launch_tiled(_kernel("cholesky"), [4096], inputs=[], block_dim=32)
        fake_warp.capture_while("nsolving", while_body=solver_iteration, m="model")
        fake_warp.capture_if("cond", on_true=lambda: fake_warp.launch(_kernel("narrow"), 1))
    assert sorted(launched) == [("cholesky", 32), ("narrow", 256), ("smooth", 256), ("solver", 256)]
    assert not ran  # neither a kernel nor a graph ran
    assert {name: getattr(fake_warp, name) for name in originals} == originals  # restored


def _cuda_step(fake_warp, monkeypatch, step):
    """A fake MuJoCo Warp whose step is `step(model, data)` (`data.nworld`, the buffer sizes),
    and a CUDA device in `fake_warp` with its launches unset (the preload records them)."""
    fake_mjw = types.SimpleNamespace(
        put_model=lambda mj_model: types.SimpleNamespace(opt=types.SimpleNamespace()),
        make_data=lambda mj_model, nworld, **sizes: types.SimpleNamespace(nworld=nworld, **sizes),
        step=step,
    )
    monkeypatch.setitem(sys.modules, "mujoco.mjx.third_party.mujoco_warp", fake_mjw)
    monkeypatch.setattr(
        sys.modules["mujoco.mjx.third_party"], "mujoco_warp", fake_mjw, raising=False
    )
    fake_warp.is_cuda_available = lambda: True
    fake_warp.get_cuda_device = lambda ordinal: f"cuda:{ordinal}"
    fake_warp.ScopedDevice = lambda device: contextlib.nullcontext()
    for name in ("launch", "launch_tiled", "capture_while", "capture_if"):
        setattr(fake_warp, name, None)
    return fake_mjw


def test_warp_preload_compiles_every_launched_module_in_threads(fake_warp, monkeypatch, caplog):
    loaded, threads, options = [], set(), {}

    class Module:
        def __init__(self, name):
            self.name = name

        def load(self, device, block_dim):
            loaded.append((self.name, device, block_dim))
            threads.add(threading.get_ident())
            time.sleep(0.05)  # a compile: the others start meanwhile

    def step(model, data):
        options.update(vars(model.opt))
        for name in ("smooth", "passive", "solver"):
            fake_warp.launch(types.SimpleNamespace(module=Module(name)), data.nworld)

    def load_module(name, device):
        raise RuntimeError(f"Module '{name}' does not contain any Warp kernels")

    fake_warp.is_cuda_available = lambda: False
    assert warp_preload.preload(None, {}, {}) == 0 and not loaded  # no CUDA device: nothing
    fake_mjw = _cuda_step(fake_warp, monkeypatch, step)
    fake_warp.load_module = load_module  # MJX's own module absent: skipped
    count = warp_preload.preload(None, {"graph_conditional": True}, {"njmax": 64})
    assert sorted(loaded) == [(name, "cuda:0", 256) for name in ("passive", "smooth", "solver")]
    assert len(threads) > 1 and options == {"graph_conditional": True} and count == 3
    loaded.clear()
    fake_mjw.step = lambda model, data: fake_warp.capture_while(None)  # a Warp it cannot record
    with caplog.at_level(logging.WARNING):
        assert warp_preload.preload(None, {}, {}) == 0  # the run goes on: kernels at launch
    assert not loaded and "not recorded" in caplog.text and fake_warp.launch is None  # restored


def test_a_deferred_preload_returns_while_the_step_compiles_and_wait_joins_it(
    fake_warp, monkeypatch
):
    compiling, loaded = threading.Event(), []

    class Module:
        def __init__(self, name):
            self.name = name

        def load(self, device, block_dim):
            assert compiling.wait(10)  # a compile that lasts until the test ends it
            loaded.append(self.name)

    modules = [Module("smooth"), Module("solver")]

    def step(model, data):
        for module in modules:
            fake_warp.launch(types.SimpleNamespace(module=module), 1)

    _cuda_step(fake_warp, monkeypatch, step)
    fake_warp.load_module = lambda name, device: loaded.append(name)  # MJX's own: waited for
    with warp_preload.deferred():
        assert warp_preload.preload(None, {}, {}) == 3
        assert warp_preload.preload(None, {}, {}) == 3  # a second env of the model
    assert loaded == ["mujoco.mjx.warp.ffi"] * 2  # the step's two modules still compiling
    compiling.set()
    assert warp_preload.wait() == 3 and warp_preload.wait() == 0
    assert sorted(loaded) == ["mujoco.mjx.warp.ffi"] * 2 + ["smooth", "solver"]  # each once
