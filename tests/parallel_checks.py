"""Data-parallel training on the toy env, run by tests/test_parallel.py in a subprocess whose
XLA_FLAGS give the CPU two devices (they must be set before JAX starts), or as one process of a
`jax.distributed` run. Prints one JSON object of measurements for the test to assert on.

    python tests/parallel_checks.py devices RUN_DIR
    python tests/parallel_checks.py process RUN_DIR COORDINATOR NUM_PROCESSES PROCESS_ID
"""

import json
import pathlib
import re
import shutil
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

import jax
import numpy as np

from quadcos import training
from quadcos.training import parallel, reuse
from tests.toy_env import CHUNK, PointEnv, toy_config


def replicas_identical(tree) -> bool:
    """Whether every device holds the same values of every (replicated) leaf."""
    for leaf in jax.tree.leaves(tree):
        shards = [np.asarray(shard.data) for shard in leaf.addressable_shards]
        if not all(np.array_equal(shards[0], shard) for shard in shards[1:]):
            return False
    return True


def replicated_state(state):
    return (
        state.policy_params,
        state.q_params,
        state.target_q_params,
        state.log_alpha,
        state.policy_optimizer_state,
        state.q_optimizer_state,
        state.normalizer_params,
        state.key,
    )


def collectives(trainer: training.SACTrainer) -> list[str]:
    """The cross-device operations of the trainer's compiled 2-device training chunk (a loop of
    env steps, each with one update: its body's operations, once), as "kind what" (what:
    "gradients" for a reduction of the update's gradients, else the JAX operation XLA's
    partitioner made it from). The chunk its runs compile: nothing compiled for it alone."""
    return _collectives(trainer.train_chunk.lower(trainer.prefill(trainer.init())))


def eval_collectives(trainer: training.SACTrainer) -> list[str]:
    """The cross-device operations of the trainer's compiled 2-device training-time
    evaluation."""
    state = trainer.init()
    keys = jax.random.split(jax.random.PRNGKey(0), trainer.config.num_eval_envs)
    lowered = trainer._evaluate_compiled.lower(
        state.normalizer_params, state.policy_params, keys, trainer._eval_gait
    )
    return _collectives(lowered)


def _collectives(lowered) -> list[str]:
    text = lowered.compile().as_text()
    found = []
    for line in text.splitlines():
        kind = re.search(
            r" (all-reduce|all-gather|all-to-all|collective-permute|reduce-scatter)(-start)?\(",
            line,
        )
        if kind:
            name = re.search(r'op_name="([^"]+)"', line)
            name = name.group(1) if name else ""
            what = "gradients" if "jvp(" in name else name.split("/")[-1]
            found.append(f"{kind.group(1)} {what}")
    return sorted(found)


class PerDevicePointEnv(PointEnv):
    """The toy env, stepped as the trainer steps MJX-Warp's: by each device on its own envs."""

    impl = "warp"


def devices(run_dir: pathlib.Path) -> dict:
    env = PointEnv()
    shardy = jax.config.jax_use_shardy_partitioner  # before any trainer runs over the mesh
    # One trainer per device count, its programs traced once: the runs below differ from it
    # only in what no program reads (`quadcos.training.reuse`).
    trainers = {count: training.SACTrainer(env, toy_config(num_devices=count)) for count in (1, 2)}
    out = {
        "device_count": jax.device_count(),
        "collectives": collectives(trainers[2]),
        "shardy": shardy,
    }
    out["eval_collectives"] = eval_collectives(trainers[2])
    try:  # n-step returns keep their queue on one device: refused over two
        training.SACTrainer(env, toy_config(num_devices=2, n_step=3))
        out["n_step_refused"] = None
    except ValueError as error:
        out["n_step_refused"] = str(error)
    per_device_trainer = training.SACTrainer(PerDevicePointEnv(), toy_config(num_devices=2))
    per_device_collectives = collectives(per_device_trainer)  # before a run compiles it ahead
    per_device = training.train(
        PerDevicePointEnv(), toy_config(num_devices=2), progress=False, trainer=per_device_trainer
    )
    out["per_device"] = {
        "collectives": per_device_collectives,
        "final_eval_reward": per_device.metrics["eval/episode_reward"],
        "obs_sharding": str(per_device.state.env_state.obs.sharding.spec),
        "shardy": jax.config.jax_use_shardy_partitioner,
    }
    for count in (1, 2):
        result = training.train(
            env, toy_config(num_devices=count), progress=False, trainer=trainers[count]
        )
        out[f"d{count}"] = {
            "first_eval_reward": result.history[0]["eval/episode_reward"],
            "final_eval_reward": result.metrics["eval/episode_reward"],
            "critic_loss": [row["train/critic_loss"] for row in result.history[1:]],
            "replay_sizes": np.atleast_1d(np.asarray(result.state.replay.size)).tolist(),
            "env_steps": result.env_steps,
            "obs_sharding": str(result.state.env_state.obs.sharding.spec) if count == 2 else None,
            "replicas_identical": replicas_identical(replicated_state(result.state)),
        }
    # A checkpoint with its replay buffer, saved on 2 devices, resumed on 1, and back on 2.
    resumed = {}
    config = toy_config(num_devices=2, save_replay=True, num_timesteps=3 * CHUNK)
    training.train(env, config, run_dir, progress=False, trainer=reuse.for_run(trainers[2], config))
    for count, until in ((1, 5 * CHUNK), (2, 7 * CHUNK)):
        config = toy_config(num_devices=count, save_replay=True, num_timesteps=until)
        result = training.train(
            env,
            config,
            run_dir,
            resume=True,
            progress=False,
            trainer=reuse.for_run(trainers[count], config),
        )
        resumed[f"on_{count}"] = {
            "env_steps": result.env_steps,
            "replay_size": int(np.sum(np.asarray(result.state.replay.size))),
            "rows": len(result.history),
            "final_eval_reward": result.metrics["eval/episode_reward"],
        }
    out["resumed"] = resumed
    try:
        training.train(env, toy_config(num_devices=2, num_envs=15), progress=False)
        out["odd_num_envs_error"] = None
    except ValueError as error:
        out["odd_num_envs_error"] = str(error)
    return out


def process(run_dir: pathlib.Path, coordinator: str, num_processes: int, process_id: int) -> dict:
    parallel.initialize_distributed(coordinator, num_processes, process_id)
    result = training.train(PointEnv(), toy_config(), run_dir, progress=False)
    return {
        **robot_on_this_process(),
        "process_index": jax.process_index(),
        "device_count": jax.device_count(),
        "local_device_count": jax.local_device_count(),
        "env_steps": result.env_steps,
        "final_eval_reward": result.metrics.get("eval/episode_reward"),
        "policy_checksum": float(
            sum(np.abs(np.asarray(leaf)).sum() for leaf in jax.tree.leaves(result.policy.params))
        ),
    }


def robot_on_this_process() -> dict:
    """The paper's robot built in this process of several: whether its model and a reset's
    state live on this process's devices (MJX's default device is the first of all processes'),
    and its position after a jitted reset and step."""
    import quadcos  # the toy checks need no MJX

    env = quadcos.make_env("flat")
    state = jax.jit(env.reset)(jax.random.PRNGKey(0))
    leaves = jax.tree.leaves((env.model, state))
    state = jax.jit(env.step)(state, jax.numpy.zeros(env.action_size))
    return {
        "robot_addressable": all(leaf.is_fully_addressable for leaf in leaves),
        "robot_height": float(state.pipeline_state.qpos[2]),
    }


def warp() -> dict:
    """The paper's robot stepped by MJX-Warp on each of two devices and by MJX-JAX (split by
    the partitioner): the robots' positions after a prefill and a training chunk."""
    import quadcos  # the toy checks need no MJX

    positions = {}
    for impl in ("jax", "warp"):
        config = toy_config(num_devices=2, num_envs=4, num_eval_envs=2, batch_size=8)
        config.update(min_replay_size=40, steps_per_chunk=5, replay_size=256)
        trainer = training.SACTrainer(quadcos.make_env("flat", impl=impl), config)
        state = trainer.prefill(trainer.init())
        if impl == "warp":  # the physics calls: how many robots each steps, and any gather
            text = trainer.train_chunk.lower(state).compile().as_text()
            calls = re.findall(r"= \(f32\[(\d+),[^\n]*custom-call\(", text)
            positions["warp_call_rows"] = sorted({int(rows) for rows in calls})
            positions["all_gathers"] = len(re.findall(r" all-gather(-start)?\(", text))
        state, _ = trainer.train_chunk(state)
        metrics = trainer.evaluate(state.normalizer_params, state.policy_params)
        positions[f"{impl}_eval_reward"] = float(metrics["eval/episode_reward"])
        positions[impl] = np.asarray(state.env_state.pipeline_state.qpos[:, :3]).tolist()
        shards = state.env_state.pipeline_state.qpos.addressable_shards
        positions[f"{impl}_shard_rows"] = [shard.data.shape[0] for shard in shards]
    return positions


if __name__ == "__main__":
    mode, run_dir = sys.argv[1], pathlib.Path(sys.argv[2])
    if mode == "warp":
        print(json.dumps(warp()))
    elif mode == "devices":
        shutil.rmtree(run_dir, ignore_errors=True)
        print(json.dumps(devices(run_dir)))
    else:
        coordinator, num_processes, process_id = sys.argv[3], int(sys.argv[4]), int(sys.argv[5])
        print(json.dumps(process(run_dir, coordinator, num_processes, process_id)))
