"""Robot specs resolved to MJCF files (`quadcos.robot.sources`), MJCF prepared for MJX
(`quadcos.robot.prepare`), and the test quadruped quad12 with its variants (tests/robot_variants.py).

The Menagerie files are the XML-only copies beside the checkout (../shared/menagerie, as in CI);
the tests that read them are skipped where that folder is absent.
"""

import dataclasses
import pathlib
import sys
import types
from xml.etree import ElementTree

import mujoco
import numpy as np
import pytest
from mujoco import mjx

from quadcos import robot as robot_lib
from quadcos import terrain
from quadcos.robot import constants, prepare, sources
from tests import robot_variants

MENAGERIE = pathlib.Path(__file__).resolve().parents[2] / "shared" / "menagerie"
needs_menagerie = pytest.mark.skipif(
    not MENAGERIE.is_dir(), reason=f"no Menagerie XML copies at {MENAGERIE}"
)
GO1 = MENAGERIE / "unitree_go1" / "go1.xml"
ANYMAL_C = MENAGERIE / "anybotics_anymal_c" / "anymal_c.xml"
GO1_FEET = ("FR", "FL", "RR", "RL")
QUAD12_FEET = ("FR", "FL", "RR", "RL")
STAND_SECONDS = 5.0
STAND_TOLERANCE = 0.05  # fraction of the keyframe's trunk height


def _one_line(error: pytest.ExceptionInfo) -> str:
    message = str(error.value)
    assert message and "\n" not in message
    return message


@pytest.fixture
def menagerie_root(tmp_path, monkeypatch):
    """A Menagerie-like folder: unitree_go1/go1.xml (quad12's XML) and a README listing commits."""
    (tmp_path / "unitree_go1").mkdir()
    (tmp_path / "unitree_go1" / "go1.xml").write_text(robot_variants.QUAD12.read_text())
    (tmp_path / "unitree_go1" / "scene.xml").write_text("<mujoco/>")
    (tmp_path / "README.md").write_text(
        "| folder | files |\n|---|---|\n"
        "| unitree_go1 | go1.xml, other.xml (d82891f), scene.xml (55017c5), LICENSE* |\n"
    )
    monkeypatch.setenv("MENAGERIE_ROOT", str(tmp_path))
    return tmp_path


@pytest.fixture
def no_registrations(monkeypatch):
    monkeypatch.setattr(sources, "_REGISTRY", {})


# --- sources.resolve -------------------------------------------------------------------------


@pytest.mark.parametrize("spec", ["", "quadcos", "  quadcos "])
def test_the_default_is_the_papers_robot(spec):
    source = sources.resolve(spec)
    assert (source.spec, source.name) == ("quadcos", "quadcos")
    assert source.path == constants.MJCF_DIR / "quadruped.xml" == constants.MJCF_PATH
    assert source.menagerie_commit is None


def test_quad12_is_built_in():
    source = sources.resolve("quad12")
    assert (source.spec, source.name, source.path) == (
        "quad12",
        "quad12",
        constants.MJCF_DIR / "quad12.xml",
    )


def test_a_relative_path_resolves_from_the_current_directory(tmp_path, monkeypatch):
    (tmp_path / "robots").mkdir()
    (tmp_path / "robots" / "my_dog.xml").write_text("<mujoco/>")
    monkeypatch.chdir(tmp_path)
    source = sources.resolve("robots/my_dog.xml")
    assert source.path == tmp_path / "robots" / "my_dog.xml"
    assert (source.spec, source.name) == (str(source.path), "my_dog")
    assert sources.resolve("robots/../robots/my_dog.xml") == source


def test_a_missing_path_is_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError) as error:
        sources.resolve(str(tmp_path / "nowhere.xml"))
    assert _one_line(error) == f"robot MJCF not found: {tmp_path / 'nowhere.xml'}"


def test_an_unknown_name_lists_the_known_ones(no_registrations):
    with pytest.raises(ValueError) as error:
        sources.resolve("go1")
    assert _one_line(error).startswith("unknown robot 'go1'; known: quad12, quadcos, an MJCF path")


def test_registered_paths_and_factories(tmp_path, no_registrations):
    path = tmp_path / "dog.xml"
    path.write_text("<mujoco/>")
    calls = []
    sources.register("dog", path)
    sources.register("dog_factory", lambda: calls.append(1) or str(path))
    assert sources.resolve("dog") == sources.RobotSource("dog", "dog", path)
    assert sources.resolve("dog_factory").path == path and calls == [1]
    assert sources.resolve("dog_factory").name == "dog_factory" and calls == [1, 1]
    assert sources.names() == ["dog", "dog_factory", "quad12", "quadcos"]


def test_registering_bad_names_and_values(tmp_path, no_registrations):
    for name in ("quad12", "2dog", "my dog", "dog.xml", ""):
        with pytest.raises(ValueError) as error:
            sources.register(name, tmp_path / "dog.xml")
        assert repr(name) in _one_line(error)
    with pytest.raises(TypeError):
        sources.register("dog", 3)
    sources.register("ghost", tmp_path / "ghost.xml")
    with pytest.raises(FileNotFoundError, match="robot MJCF not found"):
        sources.resolve("ghost")
    sources.register("broken", lambda: None)
    with pytest.raises(TypeError, match="'broken' returned NoneType"):
        sources.resolve("broken")


def test_menagerie_root_default_and_named_files(menagerie_root):
    source = sources.resolve("menagerie:unitree_go1")
    assert source == sources.RobotSource(
        "menagerie:unitree_go1",
        "unitree_go1",
        menagerie_root / "unitree_go1" / "go1.xml",
        "d82891f",
    )
    scene = sources.resolve("menagerie:unitree_go1/scene.xml")
    assert scene.path.name == "scene.xml" and scene.menagerie_commit == "55017c5"


def test_menagerie_commit_is_none_without_a_readme_row(menagerie_root):
    (menagerie_root / "README.md").unlink()
    assert sources.resolve("menagerie:unitree_go1").menagerie_commit is None


def test_menagerie_errors(menagerie_root, monkeypatch):
    with pytest.raises(ValueError) as error:
        sources.resolve("menagerie:unitree_go3")
    assert _one_line(error).startswith("unknown Menagerie robot 'unitree_go3'; close: unitree_go")
    assert "unitree_go1" in str(error.value) and "unitree_go2" in str(error.value)
    with pytest.raises(FileNotFoundError) as error:  # a Menagerie robot this root lacks
        sources.resolve("menagerie:unitree_go2")
    assert _one_line(error).endswith(
        f"not under MENAGERIE_ROOT={menagerie_root}; it holds: unitree_go1"
    )
    with pytest.raises(FileNotFoundError, match="robot MJCF not found: .*go1_mjx.xml"):
        sources.resolve("menagerie:unitree_go1/go1_mjx.xml")
    monkeypatch.setenv("MENAGERIE_ROOT", str(menagerie_root / "absent"))
    with pytest.raises(FileNotFoundError, match="MENAGERIE_ROOT is not a folder: .*absent"):
        sources.resolve("menagerie:unitree_go1")
    for spec in ("menagerie:", "menagerie:unitree_go1/go1", "menagerie:a/b/c.xml"):
        with pytest.raises(ValueError, match="bad Menagerie robot spec"):
            sources.resolve(spec)


def test_menagerie_folder_without_a_default_file_needs_one_named(menagerie_root):
    (menagerie_root / "my_dog").mkdir()
    (menagerie_root / "my_dog" / "dog.xml").write_text("<mujoco/>")
    assert sources.resolve("menagerie:my_dog/dog.xml").name == "my_dog"
    with pytest.raises(ValueError, match=r"name one: menagerie:my_dog/FILE.xml"):
        sources.resolve("menagerie:my_dog")


def test_menagerie_without_root_or_package_says_what_to_install(monkeypatch):
    monkeypatch.delenv("MENAGERIE_ROOT", raising=False)
    monkeypatch.setitem(sys.modules, "mujoco_menagerie", None)  # import fails
    with pytest.raises(ImportError) as error:
        sources.resolve("menagerie:unitree_go1")
    assert "MENAGERIE_ROOT" in _one_line(error) and "quadcos[menagerie]" in str(error.value)


def _fake_package(folder: pathlib.Path | None) -> types.ModuleType:
    """The part of mujoco-menagerie's API (2026.10.4) that sources uses; `folder` None: every
    download fails as the package's own DownloadError does."""

    class MenagerieError(Exception):
        pass

    class Robot:
        def __init__(self, name):
            self.name, self.category, self.default_model = name, "quadruped", "go1"

        def entry(self, name):
            return types.SimpleNamespace(file=f"{name}.xml")

        def path(self, cache=None, progress=None):
            if folder is None:
                raise MenagerieError(f"https://example.invalid/{self.name}.tar.xz: HTTP 404")
            return folder

    package = types.ModuleType("mujoco_menagerie")
    package.MenagerieError = MenagerieError
    package.names = lambda: ["unitree_go1", "unitree_go2", "unitree_g1"]
    package.get = Robot
    package.commit = lambda: "cda5236f98383f6fbaa4820c6b18dba892cd087f"
    return package


def test_menagerie_through_the_package(tmp_path, monkeypatch):
    monkeypatch.delenv("MENAGERIE_ROOT", raising=False)
    (tmp_path / "go1.xml").write_text("<mujoco/>")
    monkeypatch.setitem(sys.modules, "mujoco_menagerie", _fake_package(tmp_path))
    source = sources.resolve("menagerie:unitree_go1")
    assert source.path == tmp_path / "go1.xml"
    assert source.menagerie_commit == "cda5236f98383f6fbaa4820c6b18dba892cd087f"
    with pytest.raises(
        ValueError, match="unknown Menagerie robot 'unitree_go3'; close: unitree_go"
    ):
        sources.resolve("menagerie:unitree_go3")


def test_a_failed_download_names_the_variables_to_set(monkeypatch):
    monkeypatch.delenv("MENAGERIE_ROOT", raising=False)
    monkeypatch.setitem(sys.modules, "mujoco_menagerie", _fake_package(None))
    with pytest.raises(OSError) as error:
        sources.resolve("menagerie:unitree_go1")
    message = _one_line(error)
    assert "HTTP 404" in message
    assert all(
        name in message for name in ("MENAGERIE_ROOT", "MENAGERIE_CACHE_DIR", "MENAGERIE_BASE_URL")
    )


def test_the_real_package_from_a_warm_cache(tmp_path, monkeypatch):
    """Against mujoco-menagerie itself where it is installed (the `menagerie` extra)."""
    package = pytest.importorskip("mujoco_menagerie")
    monkeypatch.delenv("MENAGERIE_ROOT", raising=False)
    monkeypatch.setenv("MENAGERIE_CACHE_DIR", str(tmp_path))
    folder = package.Cache().model_path(package.get("unitree_go1"))
    folder.mkdir(parents=True)
    (folder / "go1.xml").write_text("<mujoco/>")
    (folder / ".complete").write_text("{}")  # the package's mark of a finished download
    source = sources.resolve("menagerie:unitree_go1")
    assert source.path == folder / "go1.xml" and source.menagerie_commit == package.commit()
    with pytest.raises(
        ValueError, match="unknown Menagerie robot 'franka_emika_panda'; quadrupeds"
    ):
        sources.resolve("menagerie:franka_emika_panda")  # refused before any download


@needs_menagerie
def test_the_shared_menagerie_copies_resolve(monkeypatch):
    monkeypatch.setenv("MENAGERIE_ROOT", str(MENAGERIE))
    go1 = sources.resolve("menagerie:unitree_go1")
    assert go1.path == GO1 and go1.menagerie_commit == "d82891f"
    anymal = sources.resolve("menagerie:anybotics_anymal_c")
    assert anymal.path == ANYMAL_C and anymal.menagerie_commit == "d82891f"
    assert sources.resolve("menagerie:unitree_go2/go2_mjx.xml").menagerie_commit == "d4da3fd"


# --- prepare.load_spec -----------------------------------------------------------------------

_DRAWN_ROBOT = """
<mujoco>
  <asset>
    <mesh name="shell" file="shell.stl"/>
    <texture name="paint" type="2d" file="paint.png"/>
    <texture name="grid" type="2d" builtin="checker" width="8" height="8"/>
    <material name="painted" texture="paint"/>
    <material name="gridded" texture="grid"/>
    <material name="plain" rgba="1 0 0 1"/>
  </asset>
  <worldbody>
    <body name="base" pos="0 0 1">
      <freejoint/>
      <inertial pos="0 0 0" mass="2" diaginertia="0.1 0.1 0.1"/>
      <geom type="mesh" mesh="shell" material="painted"/>
      <geom name="decal" type="box" size="0.1 0.1 0.01" group="2" contype="0" conaffinity="0"/>
      <geom name="hull" type="box" size="0.2 0.1 0.05" material="painted"/>
      <geom name="hidden" type="sphere" size="0.05" contype="0" conaffinity="0" material="gridded"/>
      <site name="marker" material="painted"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_load_spec_strips_what_draws(tmp_path):
    path = tmp_path / "drawn.xml"
    path.write_text(_DRAWN_ROBOT)
    spec = prepare.load_spec(path)
    assert [geom.name for geom in spec.geoms] == ["hull", "hidden"]
    assert not spec.meshes
    assert [texture.name for texture in spec.textures] == ["grid"]
    assert [material.name for material in spec.materials] == ["gridded", "plain"]
    assert spec.geom("hull").material == "" and spec.site("marker").material == ""
    model = spec.compile()
    assert model.body_mass[1] == pytest.approx(2.0)


def test_load_spec_refuses_a_body_weighed_by_its_mesh(tmp_path):
    path = tmp_path / "heavy_mesh.xml"
    path.write_text(
        _DRAWN_ROBOT.replace('<inertial pos="0 0 0" mass="2" diaginertia="0.1 0.1 0.1"/>', "")
    )
    with pytest.raises(ValueError) as error:
        prepare.load_spec(path)
    assert _one_line(error) == (
        f"robot MJCF {path}: body 'base' takes its mass from a mesh or visual geom, which quadcos"
        " strips; give the body an <inertial>"
    )


def test_load_spec_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="robot MJCF not found: .*absent.xml"):
        prepare.load_spec(tmp_path / "absent.xml")
    path = tmp_path / "broken.xml"
    path.write_text('<mujoco><worldbody><geom type="bogus"/></worldbody></mujoco>')
    with pytest.raises(ValueError) as error:
        prepare.load_spec(path)
    assert _one_line(error).startswith(f"robot MJCF {path} could not be parsed: XML Error:")
    assert "bogus" in str(error.value)


def _inertial_mass(path: pathlib.Path) -> float:
    """Sum of the file's <inertial> masses, read from the XML itself."""
    root = ElementTree.parse(path).getroot()
    return sum(float(inertial.get("mass")) for inertial in root.iter("inertial"))


@needs_menagerie
@pytest.mark.parametrize("path", [GO1, ANYMAL_C], ids=["go1", "anymal_c"])
def test_menagerie_robots_compile_without_their_meshes(path):
    spec = prepare.load_spec(path)
    model = spec.compile()
    assert mujoco.mjtGeom.mjGEOM_MESH not in model.geom_type
    assert model.nmesh == 0 and model.ntex == 0 and model.nu == 12 and model.njnt == 13
    assert model.body_subtreemass[1] == pytest.approx(_inertial_mass(path))


# --- geom indices -----------------------------------------------------------------------------


def _matches(spec: mujoco.MjSpec, model: mujoco.MjModel) -> bool:
    """Whether spec.geoms[i] is model geom i, for every i (name, type and body)."""
    return len(spec.geoms) == model.ngeom and all(
        (geom.name, int(geom.type), geom.parent.name)
        == (model.geom(i).name, int(model.geom_type[i]), model.body(model.geom_bodyid[i]).name)
        for i, geom in enumerate(spec.geoms)
    )


def _sphere_ids(model: mujoco.MjModel) -> list[int]:
    return [i for i in range(model.ngeom) if model.geom_type[i] == mujoco.mjtGeom.mjGEOM_SPHERE]


@needs_menagerie
def test_geom_indices_are_compiled_geom_ids():
    """ANYmal C's feet have no names: a model compiled from one load_spec gives their ids, which
    index the geoms of another; a ground attached first comes first and shifts them by one."""
    anymal_feet = _sphere_ids(prepare.load_spec(ANYMAL_C).compile())
    assert len(anymal_feet) == 4
    spec = prepare.load_spec(ANYMAL_C)
    prepare.apply_collision_profile(spec, anymal_feet, "feet")
    model = spec.compile()
    assert _matches(spec, model)
    colliding = [
        i for i in range(model.ngeom) if model.geom_contype[i] or model.geom_conaffinity[i]
    ]
    assert colliding == anymal_feet
    terrain.get("flat").attach(spec)
    assert _matches(spec, spec.compile())
    assert spec.geoms[0].name == terrain.FLOOR_GEOM
    assert [i - 1 for i in _sphere_ids(spec.compile())] == anymal_feet


# --- prepare.apply_collision_profile ---------------------------------------------------------


@needs_menagerie
@pytest.mark.parametrize(
    ("path", "failing_ground", "failure"),
    [
        (
            GO1,
            "slope5",
            r"\(mjtGeom.mjGEOM_HFIELD, mjtGeom.mjGEOM_BOX\) margin/gap not implemented",
        ),
        (
            ANYMAL_C,
            "flat",
            r"\(mjtGeom.mjGEOM_CYLINDER, mjtGeom.mjGEOM_BOX\) collisions not implemented",
        ),
    ],
    ids=["go1-slope5", "anymal_c-flat"],
)
def test_mjx_takes_menagerie_robots_with_the_feet_profile(path, failing_ground, failure):
    feet = GO1_FEET if path == GO1 else _sphere_ids(prepare.load_spec(path).compile())
    as_is = prepare.load_spec(path)
    terrain.get(failing_ground).attach(as_is)
    with pytest.raises(NotImplementedError, match=failure):
        mjx.put_model(as_is.compile(), impl="jax")
    for ground in ("flat", "slope5"):
        spec = prepare.load_spec(path)
        prepare.apply_collision_profile(spec, feet, "feet")
        terrain.get(ground).attach(spec)
        model = spec.compile()
        mjx.put_model(model, impl="jax")
        assert not model.geom_margin.any() and not model.geom_gap.any()


def test_the_feet_profile_pairs_feet_with_the_ground_as_the_papers_robot():
    paper = mujoco.MjModel.from_xml_path(str(constants.MJCF_PATH))
    paper_foot = paper.geom(constants.FEET[0])
    spec = prepare.load_spec(constants.MJCF_DIR / "quad12.xml")
    prepare.apply_collision_profile(spec, QUAD12_FEET)
    terrain.get("flat").attach(spec)
    model = spec.compile()
    for i in range(model.ngeom):
        name = model.geom(i).name
        if name in QUAD12_FEET:
            assert (model.geom_contype[i], model.geom_conaffinity[i]) == (
                paper_foot.contype[0],
                paper_foot.conaffinity[0],
            )
        elif name != terrain.FLOOR_GEOM:
            assert model.geom_contype[i] == model.geom_conaffinity[i] == 0, name
    mujoco.mj_resetDataKeyframe(model, data := mujoco.MjData(model), 0)
    mujoco.mj_forward(model, data)
    touching = {model.geom(g).name for contact in data.contact for g in contact.geom}
    assert touching == {*QUAD12_FEET, terrain.FLOOR_GEOM}


def test_the_all_profile_keeps_collisions_and_zeroes_margins():
    before = prepare.load_spec(constants.MJCF_DIR / "quad12.xml").compile()
    spec = prepare.load_spec(constants.MJCF_DIR / "quad12.xml")
    prepare.apply_collision_profile(spec, [], "all")
    after = spec.compile()
    assert before.geom_margin.any() and not after.geom_margin.any() and not after.geom_gap.any()
    np.testing.assert_array_equal(after.geom_contype, before.geom_contype)
    np.testing.assert_array_equal(after.geom_conaffinity, before.geom_conaffinity)


def test_the_feet_profile_removes_pairs_of_silenced_geoms():
    spec = prepare.load_spec(constants.MJCF_DIR / "quad12.xml")
    spec.add_pair(geomname1="trunk", geomname2="FR")
    spec.add_pair(geomname1="FL", geomname2="FR")
    prepare.apply_collision_profile(spec, QUAD12_FEET)
    assert [(pair.geomname1, pair.geomname2) for pair in spec.pairs] == [("FL", "FR")]


def test_collision_profile_errors():
    spec = prepare.load_spec(constants.MJCF_DIR / "quad12.xml")
    terrain.get("flat").attach(spec)
    cases = {
        ("FR", "sideways"): "unknown collision profile 'sideways'; known: feet, all",
        ("nose", "feet"): "no geom named 'nose'",
        ("", "feet"): "no geom named ''",
        (99, "feet"): "foot geom 99 is neither a geom name nor an index below 18",
        (True, "feet"): "foot geom True is neither a geom name nor an index below 18",
        (terrain.FLOOR_GEOM, "feet"): "foot geom 'floor' belongs to the world body",
        (0, "feet"): "foot geom 'floor' belongs to the world body",
    }
    for (foot, profile), message in cases.items():
        with pytest.raises(ValueError) as error:
            prepare.apply_collision_profile(spec, [foot], profile)
        assert _one_line(error) == message
    with pytest.raises(ValueError, match="needs at least one foot geom"):
        prepare.apply_collision_profile(spec, [], "feet")
    prepare.apply_collision_profile(spec, [np.int64(17)], "feet")  # NumPy ints are indices too
    assert spec.geoms[17].name == "RL" and spec.geoms[17].contype == prepare.FOOT_CONTYPE


# --- quad12 and its variants -----------------------------------------------------------------


def _trunk_height_after(
    path: pathlib.Path, *, torque_kp: float | None = None
) -> tuple[float, float]:
    """(keyframe trunk height, trunk height after STAND_SECONDS) on flat ground in C MuJoCo, from
    the keyframe (or, without one, qpos0 with quad12's home joint angles). With `torque_kp` the
    actuators are motors driven by a P controller towards the home angles."""
    spec = mujoco.MjSpec.from_file(str(path))
    terrain.get("flat").attach(spec)
    model = spec.compile()
    data = mujoco.MjData(model)
    reference = mujoco.MjModel.from_xml_path(str(robot_variants.QUAD12))
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    else:
        data.qpos[:], data.ctrl[:] = reference.key_qpos[0], reference.key_ctrl[0]
    home = data.qpos[7:].copy()
    start = data.qpos[2]
    for _ in range(round(STAND_SECONDS / model.opt.timestep)):
        if torque_kp is not None:
            data.ctrl[:] = np.clip(torque_kp * (home - data.qpos[7:]), *model.actuator_ctrlrange.T)
        mujoco.mj_step(model, data)
    assert np.linalg.norm(data.qpos[4:6]) < 0.05, "the trunk tilted"
    return start, data.qpos[2]


def test_quad12_is_a_go1_sized_quadruped():
    model = mujoco.MjModel.from_xml_path(str(constants.MJCF_DIR / "quad12.xml"))
    assert model.body_subtreemass[1] == pytest.approx(12.72)
    assert model.nu == 12 and model.nq == 19 and model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    assert model.opt.timestep == 0.002
    np.testing.assert_array_equal(
        model.actuator_ctrlrange, model.jnt_range[model.actuator_trnid[:, 0]]
    )
    prefixes = [model.actuator(i).name.split("_")[0] for i in range(model.nu)]
    assert prefixes == [leg for leg in QUAD12_FEET for _ in range(3)]


@pytest.mark.parametrize(
    ("variant", "torque_kp"),
    [
        (None, None),
        (robot_variants.knees_inward, None),
        (robot_variants.no_keyframe, None),
        (robot_variants.motors_without_gains, 100.0),
        (robot_variants.five_legs, None),
    ],
    ids=["quad12", "knees_inward", "no_keyframe", "motors_without_gains", "five_legs"],
)
def test_quad12_and_its_variants_stand(variant, torque_kp, tmp_path):
    path = robot_variants.QUAD12 if variant is None else variant(tmp_path)
    start, end = _trunk_height_after(path, torque_kp=torque_kp)
    assert start == pytest.approx(robot_variants.HOME_HEIGHT)
    assert end == pytest.approx(start, rel=STAND_TOLERANCE)


def test_the_variants_are_what_they_say(tmp_path):
    def model(variant):
        return mujoco.MjModel.from_xml_path(str(variant(tmp_path)))

    inward = model(robot_variants.knees_inward)
    assert inward.joint("RR_calf_joint").range.tolist() == [0.888, 2.818]
    assert inward.joint("FR_calf_joint").range.tolist() == [-2.818, -0.888]
    motors = model(robot_variants.motors_without_gains)
    assert not motors.actuator_biastype.any() and (motors.actuator_gainprm[:, 0] == 1).all()
    assert motors.actuator_ctrlrange[2].tolist() == [-35.55, 35.55]
    assert model(robot_variants.no_keyframe).nkey == 0
    assert mujoco.mjtJoint.mjJNT_FREE not in model(robot_variants.no_freejoint).jnt_type
    assert model(robot_variants.three_legs).nu == 9
    assert model(robot_variants.five_legs).nu == 15
    one_joint = model(robot_variants.one_joint_leg)
    assert one_joint.nu == 10 and one_joint.joint("RL_calf_joint").id == one_joint.njnt - 1


def test_a_presets_joint_frictionloss_replaces_the_mjcfs(monkeypatch):
    from quadcos.robot import loading, presets

    with pytest.raises(ValueError, match="joint_frictionloss must be >= 0"):
        presets.RobotPreset(joint_frictionloss=-0.1)
    with pytest.raises(ValueError, match="hfield_contacts must be a whole number >= 1"):
        presets.RobotPreset(hfield_contacts=0)
    monkeypatch.setitem(
        presets.PRESETS,
        "quad12",
        dataclasses.replace(presets.PRESETS["quad12"], joint_frictionloss=0.2),
    )
    loading.load.cache_clear()
    try:
        robot = loading.load("quad12")
        frictions = {
            j.frictionloss for j in robot.spec().joints if j.type == mujoco.mjtJoint.mjJNT_HINGE
        }
        assert frictions == {0.2}
        assert robot.summary()["physics"]["joint_frictionloss"] == 0.2
    finally:
        loading.load.cache_clear()


@needs_menagerie
def test_a_scene_with_its_own_floor_is_refused_naming_the_file():
    scene = robot_lib.load(str(GO1.parent / "scene.xml"))
    with pytest.raises(ValueError, match=r"scene\.xml\).* cannot take terrain 'flat'.*own MJCF"):
        robot_lib.build_model(terrain.get("flat"), scene, timestep=0.005)
