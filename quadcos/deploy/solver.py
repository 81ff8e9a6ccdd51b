"""C MuJoCo's constraint solver for the host robot (`quadcos.deploy.host_robot`): "reference" keeps
the MJCF's own iterations (converged), "training" the iterations the env trained with (the robot
preset's shortcut), "N/M" N solver and M line-search iterations — to find where the solver a
policy trained with stops transferring."""

import argparse
import re

import ml_collections


def iterations(physics: str, config: ml_collections.ConfigDict) -> tuple[int, int]:
    """(solver, line-search) iterations of a `physics` choice for a resolved env config (0, 0:
    the MJCF's own).

    Raises:
      ValueError: anything but "reference", "training" or "N/M" with whole numbers N, M >= 1.
    """
    if physics == "reference":
        return 0, 0
    if physics == "training":
        return config.solver_iterations, config.ls_iterations
    match = re.fullmatch(r"(\d+)/(\d+)", physics)
    if match is None or min(int(match[1]), int(match[2])) < 1:
        raise ValueError(
            f"unknown physics {physics!r}; known: reference, training, or N/M (solver and"
            " line-search iterations, each >= 1)"
        )
    return int(match[1]), int(match[2])


def physics_choice(text: str) -> str:
    """argparse type of --physics: the text, once its form is one `iterations` takes."""
    try:
        if text != "training":  # the only choice that reads the policy's config
            iterations(text, ml_collections.ConfigDict())
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return text
