"""Where a robot's MJCF comes from: a robot spec (the CLI's `--robot`) resolved to a file.

Specs:

- "" or "quadcos": the paper's robot, models/mjcf/quadruped.xml.
- "quad12": the 12-joint test quadruped, models/mjcf/quad12.xml.
- a name given to `register` from Python.
- a path to an MJCF file (relative paths from the current directory): it contains a "/" or ends
  in ".xml".
- "menagerie:NAME" or "menagerie:NAME/FILE.xml": a MuJoCo Menagerie robot, NAME its folder
  (unitree_go1, anybotics_anymal_c, ...), FILE its default model unless given. Read from
  `$MENAGERIE_ROOT/NAME/FILE` when MENAGERIE_ROOT is set (a Menagerie checkout, or any folder laid
  out ROOT/NAME/...), else through the optional `mujoco-menagerie` package, which downloads the
  model on first use into MENAGERIE_CACHE_DIR from MENAGERIE_BASE_URL (`pip install
  'quadcos[menagerie]'`).
"""

import dataclasses
import difflib
import os
import pathlib
import re
from collections.abc import Callable

from quadcos.robot import constants

MENAGERIE_PREFIX = "menagerie:"
# Menagerie's quadrupeds and the robot file (no floor) of each; for other folders give FILE.
MENAGERIE_DEFAULT_FILES = {
    "anybotics_anymal_b": "anymal_b.xml",
    "anybotics_anymal_c": "anymal_c.xml",
    "boston_dynamics_spot": "spot.xml",
    "google_barkour_v0": "barkour_v0.xml",
    "google_barkour_vb": "barkour_vb.xml",
    "unitree_a1": "a1.xml",
    "unitree_go1": "go1.xml",
    "unitree_go2": "go2.xml",
}
_BUILT_IN = {"quadcos": "quadruped.xml", "quad12": "quad12.xml"}
_NAME_PATTERN = re.compile(r"[A-Za-z][A-Za-z0-9_.-]*")
_MENAGERIE_SPEC = re.compile(r"(?P<name>[A-Za-z0-9_.-]+)(?:/(?P<file>[A-Za-z0-9_.-]+\.xml))?")
# A README row `| NAME | go2.xml, go2_mjx.xml (d4da3fd), scene.xml (55017c5) |`: a commit in
# parentheses belongs to the files listed since the previous one.
_README_FILES = re.compile(r"([A-Za-z0-9_.-]+\.xml)|\(([0-9a-f]{7,40})\)")

_REGISTRY: dict[str, pathlib.Path | Callable[[], str | os.PathLike]] = {}


class RobotUnavailable(OSError, ValueError):
    """A Menagerie robot that could not be fetched: an OSError, and a bad `--robot` where a
    command line reads it (one line naming the variable to set, exit status 2)."""


@dataclasses.dataclass(frozen=True)
class RobotSource:
    """A resolved robot spec.

    Attributes:
      spec: the spec, normalised: "quadcos" for "", an absolute path for a path, else as given.
      name: short name: "quadcos", "quad12", the registered name, the Menagerie folder
        ("unitree_go1") or the file's stem.
      path: the MJCF file to load.
      menagerie_commit: the Menagerie commit the file was read at, where known.
    """

    spec: str
    name: str
    path: pathlib.Path
    menagerie_commit: str | None = None


def register(
    name: str, path_or_factory: str | os.PathLike | Callable[[], str | os.PathLike]
) -> None:
    """Makes a robot available to `resolve` (and so to the CLI's `--robot`) under `name`.

    Args:
      name: a letter, then letters, digits, '_', '.' or '-'; not a built-in name and not ending
        in ".xml". Registering a name again replaces it.
      path_or_factory: the MJCF file, or a zero-argument function returning its path, called on
        each `resolve` (e.g. one writing a generated MJCF).

    Raises:
      ValueError: a bad or built-in name.
      TypeError: `path_or_factory` is neither a path nor callable.
    """
    if not isinstance(name, str) or not _NAME_PATTERN.fullmatch(name) or name.endswith(".xml"):
        raise ValueError(
            f"bad robot name {name!r}: expected a letter, then letters, digits, '_', '.', '-'"
            " (not ending in '.xml')"
        )
    if name in _BUILT_IN:
        raise ValueError(f"robot name {name!r} is built in; choose another")
    if isinstance(path_or_factory, (str, os.PathLike)):
        _REGISTRY[name] = pathlib.Path(path_or_factory).resolve()
    elif callable(path_or_factory):
        _REGISTRY[name] = path_or_factory
    else:
        raise TypeError(
            "path_or_factory must be a path or a callable returning one, got"
            f" {type(path_or_factory).__name__}"
        )


def names() -> list[str]:
    """The robots `resolve` knows by name (built-in and registered), sorted."""
    return sorted({*_BUILT_IN, *_REGISTRY})


def resolve(spec: str) -> RobotSource:
    """The MJCF file a robot spec names (see the module docstring for the forms).

    Raises:
      FileNotFoundError: the MJCF file does not exist.
      ValueError: an unknown name or Menagerie robot, naming the known or close ones.
      ImportError: a Menagerie spec without MENAGERIE_ROOT and without `mujoco-menagerie`.
      RobotUnavailable (an OSError): the Menagerie model could not be downloaded; says which
        variable to set.
    """
    spec = spec.strip()
    if spec in ("", "quadcos", "quad12"):
        name = spec or "quadcos"
        return RobotSource(name, name, _existing(constants.MJCF_DIR / _BUILT_IN[name]))
    if spec.startswith(MENAGERIE_PREFIX):
        return _menagerie(spec)
    if spec in _REGISTRY:
        return RobotSource(spec, spec, _existing(_registered_path(spec)))
    if "/" in spec or os.sep in spec or spec.endswith(".xml"):
        path = pathlib.Path(spec).expanduser().resolve()
        return RobotSource(str(path), path.stem, _existing(path))
    raise ValueError(
        f"unknown robot {spec!r}; known: {', '.join(names())}, an MJCF path, or"
        f" {MENAGERIE_PREFIX}NAME"
    )


def short_name(spec: str) -> str:
    """The short name `resolve(spec).name` gives, read from the spec alone (no file is opened):
    what a robot's presets are keyed by."""
    spec = spec.strip()
    if spec.startswith(MENAGERIE_PREFIX):
        return spec.removeprefix(MENAGERIE_PREFIX).split("/")[0]
    if spec in ("", "quadcos", "quad12") or spec in _REGISTRY:
        return spec or "quadcos"
    return pathlib.Path(spec).stem


def _existing(path: pathlib.Path) -> pathlib.Path:
    if not path.is_file():
        raise FileNotFoundError(f"robot MJCF not found: {path}")
    return path


def _registered_path(name: str) -> pathlib.Path:
    entry = _REGISTRY[name]
    if isinstance(entry, pathlib.Path):
        return entry
    path = entry()
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(
            f"the factory registered as robot {name!r} returned {type(path).__name__}, not a path"
        )
    return pathlib.Path(path).resolve()


def _menagerie(spec: str) -> RobotSource:
    match = _MENAGERIE_SPEC.fullmatch(spec.removeprefix(MENAGERIE_PREFIX))
    if match is None:
        raise ValueError(
            f"bad Menagerie robot spec {spec!r}: expected {MENAGERIE_PREFIX}NAME or"
            f" {MENAGERIE_PREFIX}NAME/FILE.xml"
        )
    name, file = match["name"], match["file"]
    root = os.environ.get("MENAGERIE_ROOT")
    if root:
        root_folder = pathlib.Path(root).expanduser()
        if not root_folder.is_dir():
            raise FileNotFoundError(f"MENAGERIE_ROOT is not a folder: {root}")
        folder = root_folder / name
        if not folder.is_dir():
            present = sorted(path.name for path in root_folder.iterdir() if path.is_dir())
            if name not in MENAGERIE_DEFAULT_FILES:
                raise _unknown(name, [*MENAGERIE_DEFAULT_FILES, *present])
            raise FileNotFoundError(
                f"Menagerie robot {name!r} is not under MENAGERIE_ROOT={root}; it holds:"
                f" {', '.join(present) or 'nothing'}"
            )
        commit = None
        file = file or _default_file(name)
    else:
        if name not in MENAGERIE_DEFAULT_FILES and file is None:  # before any download
            raise _unknown(name, list(MENAGERIE_DEFAULT_FILES))
        folder, commit, file = _from_package(name, file)
    path = _existing(folder / file)
    return RobotSource(spec, name, path, commit or _readme_commit(folder.parent, name, file))


def _default_file(name: str) -> str:
    if name not in MENAGERIE_DEFAULT_FILES:
        raise ValueError(
            f"Menagerie robot {name!r} has no default file in quadcos; name one:"
            f" {MENAGERIE_PREFIX}{name}/FILE.xml"
        )
    return MENAGERIE_DEFAULT_FILES[name]


def _unknown(name: str, known: list[str]) -> ValueError:
    close = difflib.get_close_matches(name, sorted(set(known)), n=3)
    hint = (
        f"; close: {', '.join(close)}"
        if close
        else f"; quadrupeds: {', '.join(MENAGERIE_DEFAULT_FILES)}"
    )
    return ValueError(f"unknown Menagerie robot {name!r}{hint}")


def _from_package(name: str, file: str | None) -> tuple[pathlib.Path, str, str]:
    """The model folder (downloaded on first use), the registry's Menagerie commit and the file."""
    try:
        import mujoco_menagerie
    except ImportError:
        raise ImportError(
            f"{MENAGERIE_PREFIX}{name} needs MENAGERIE_ROOT=<a Menagerie checkout> or the"
            " mujoco-menagerie package: pip install 'quadcos[menagerie]'"
        ) from None
    if name not in mujoco_menagerie.names():
        raise _unknown(name, [*MENAGERIE_DEFAULT_FILES, *mujoco_menagerie.names()])
    robot = mujoco_menagerie.get(name)
    if robot.category != "quadruped":
        raise ValueError(
            f"Menagerie robot {name!r} is a {robot.category} robot, not a quadruped; quadrupeds:"
            f" {', '.join(MENAGERIE_DEFAULT_FILES)}"
        )
    if file is None:
        file = MENAGERIE_DEFAULT_FILES.get(name) or robot.entry(robot.default_model).file
    try:
        folder = robot.path(progress=None)
    except mujoco_menagerie.MenagerieError as error:
        raise RobotUnavailable(
            f"could not fetch Menagerie robot {name!r} ({error}); set MENAGERIE_ROOT to a Menagerie"
            " checkout, MENAGERIE_CACHE_DIR to a cache that holds it, or MENAGERIE_BASE_URL to a"
            " reachable mirror of its archives"
        ) from None
    return folder, mujoco_menagerie.commit(), file


def _readme_commit(root: pathlib.Path, name: str, file: str) -> str | None:
    """The commit `ROOT/README.md`'s table gives for NAME's FILE (see the regex above); None when
    there is no such README or row."""
    readme = root / "README.md"
    if not readme.is_file():
        return None
    for line in readme.read_text(errors="replace").splitlines():
        cells = [cell.strip() for cell in line.split("|")]
        if len(cells) < 3 or cells[1] != name:
            continue
        pending = []
        for listed, commit in _README_FILES.findall(cells[2]):
            if listed:
                pending.append(listed)
            elif file in pending:
                return commit
            else:
                pending = []
    return None
