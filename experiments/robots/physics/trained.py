"""A trained policy under each physics: is the preset's solver shortcut stable once the robot walks fast?

    MENAGERIE_ROOT=/work/shared/menagerie python experiments/robots/physics/trained.py \
        --policy experiments/policies/go1_flat --out experiments/robots/physics/trained_go1_flat.json

The policy (trained with MJX-Warp at its robot preset's solver iterations) runs on flat ground,
deterministic 20-s episodes:
- MJX-JAX (`--mjx_episodes` at once) at the preset's iterations and at each of `--mjx_settings`
  (solver:line-search iterations, or a physics step in ms as `dtMS`);
- C MuJoCo (`quadcos.sim2sim`, `--c_episodes` one after another) with the training iterations and
  with the MJCF's converged solver (`physics="reference"`).
Per setting: success (no fall), mean forward speed, episodes whose state went NaN.
"""

import argparse
import json
import math
import pathlib

from quadcos.deploy import engines
from quadcos.evaluation import report


def _nan_episodes(episodes: list[dict]) -> int:
    return sum(1 for e in episodes if e["forward_speed"] is None or math.isnan(e["forward_speed"]))


def _row(label: str, engine: str, summary: dict, episodes: list[dict]) -> dict:
    row = {
        "setting": label,
        "engine": engine,
        "episodes": summary["num_episodes"],
        "success_rate": summary["success_rate"],
        "mean_forward_speed": summary["mean_forward_speed"],
        "nan_episodes": _nan_episodes(episodes),
    }
    print(json.dumps(row), flush=True)
    return row


def _overrides(setting: str) -> dict:
    if setting.startswith("dt"):
        return {"physics_dt": float(setting[2:]) / 1000.0}
    solver, line_search = (int(value) for value in setting.split(":"))
    return {"solver_iterations": solver, "ls_iterations": line_search}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", required=True)
    parser.add_argument("--mjx_settings", default="8:8,16:16,dt2.5")
    parser.add_argument("--mjx_episodes", type=int, default=32)
    parser.add_argument("--c_episodes", type=int, default=16)
    parser.add_argument("--out", type=pathlib.Path, required=True)
    args = parser.parse_args()
    rows = []
    for setting in ["preset", *args.mjx_settings.split(",")]:
        overrides = {} if setting == "preset" else _overrides(setting)
        result = report.evaluate(
            args.policy, "flat", num_envs=args.mjx_episodes, seconds=20.0, env_overrides=overrides
        )
        rows.append(_row(setting, "mjx-jax", result.summary, result.episodes))
    for physics in ("reference", "training"):
        result = engines.evaluate(
            args.policy, "flat", engine="mujoco", episodes=args.c_episodes, physics=physics
        )
        rows.append(_row(physics, "mujoco", result.summary, result.episodes))
    args.out.write_text(json.dumps({"policy": args.policy, "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
