"""A robot MJCF made ready for MJX: parsed without what it cannot load (`load_spec`) and given the
contacts quadcos simulates (`apply_collision_profile`).

Menagerie robots draw with meshes and textures that quadcos neither ships nor needs: their
collision geometry is primitives and every body has an explicit `<inertial>`, so stripping the
visuals leaves contact and dynamics as they were. Their contacts do not suit MJX as they are: a
geom margin makes MJX refuse a heightfield ground ("(HFIELD, BOX) margin/gap not implemented"),
and geom pairs such as ANYmal C's cylinder against box have no MJX collision function at all.
The "feet" profile lets only the feet touch the ground, as on the paper's robot.

Geoms are named by name or by index. An index is a position in `spec.geoms` at the time of the
call, which is the geom's id in the model `spec.compile()` gives at that time (MuJoCo orders both
by a depth-first walk of the body tree, world body first). So the ids of a model compiled from
`load_spec(path)` index the geoms of another `load_spec(path)` too, as long as nothing was added
to either before; a ground attached to the world body first shifts them (it comes first).
"""

import math
import operator
import pathlib
from collections.abc import Sequence

import mujoco

COLLISION_PROFILES = ("feet", "all")
CONES = ("pyramidal", "elliptic")
# The paper's feet (models/mjcf/quadruped.xml): contype 1 against the ground's conaffinity 1; the
# ground has contype 0 (quadcos.terrain.ground), so feet never collide with each other.
FOOT_CONTYPE = 1
FOOT_CONAFFINITY = 0


def load_spec(path: pathlib.Path) -> mujoco.MjSpec:
    """Parse a robot MJCF into an MjSpec without its visual geoms, meshes and image textures.

    Removed: mesh geoms and the geoms that only draw (group 2, contype = conaffinity = 0:
    Menagerie's `visual` classes), every mesh asset, textures read from files and the materials
    that use them (geoms, sites and tendons drawn with such a material lose it). Collision
    primitives, `<inertial>`s and everything else are kept.

    Args:
      path: the MJCF file (a robot, or a scene including one).

    Raises:
      FileNotFoundError: `path` does not exist.
      ValueError: the file is not valid MJCF, or a body takes its mass from a removed geom (it
        has no `<inertial>`), naming the file.
    """
    path = pathlib.Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"robot MJCF not found: {path}")
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except ValueError as error:  # the parser message, over several lines
        message = "; ".join(line.strip() for line in str(error).splitlines() if line.strip())
        raise ValueError(f"robot MJCF {path} could not be parsed: {message}") from None
    visuals = [geom for geom in spec.geoms if _is_visual(geom)]
    for geom in visuals:
        if _adds_mass(spec, geom):
            raise ValueError(
                f"robot MJCF {path}: body {geom.parent.name or '(unnamed)'!r} takes its mass from"
                " a mesh or visual geom, which quadcos strips; give the body an <inertial>"
            )
    for geom in visuals:
        spec.delete(geom)
    for mesh in list(spec.meshes):
        spec.delete(mesh)
    _strip_image_textures(spec)
    return spec


def apply_collision_profile(
    spec: mujoco.MjSpec, foot_geoms: Sequence[str | int], profile: str = "feet"
) -> None:
    """Set which robot geoms collide, in place; margin and gap 0 on every geom.

    Profiles:
      "feet": only the foot geoms touch anything: they get contype FOOT_CONTYPE and conaffinity
        FOOT_CONAFFINITY (against the ground's conaffinity 1, as the paper's robot); every other
        geom of the robot contype = conaffinity = 0, and `<pair>`s naming one are removed.
      "all": the robot's collisions as the MJCF has them.
    Geoms of the world body (a ground already in the file) keep their contype and conaffinity.
    Zero margin and gap are what MJX supports with a heightfield.

    Args:
      spec: the robot, from `load_spec`; modified in place.
      foot_geoms: the feet, each a geom name or an index into `spec.geoms` (see the module
        docstring: the geom's id in a model compiled from this spec now).
      profile: "feet" or "all".

    Raises:
      ValueError: an unknown profile, no feet for "feet", or a foot that is no robot geom.
    """
    if profile not in COLLISION_PROFILES:
        raise ValueError(
            f"unknown collision profile {profile!r}; known: {', '.join(COLLISION_PROFILES)}"
        )
    geoms = spec.geoms
    feet = {_geom_index(geoms, foot) for foot in foot_geoms}
    if profile == "feet" and not feet:
        raise ValueError("collision profile 'feet' needs at least one foot geom")
    for index in feet:
        if geoms[index].parent == spec.worldbody:
            raise ValueError(f"foot geom {_label(geoms, index)} belongs to the world body")
    for geom in geoms:
        geom.margin = 0.0
        geom.gap = 0.0
    if profile == "all":
        return
    others = {index for index, geom in enumerate(geoms) if geom.parent != spec.worldbody} - feet
    for index in feet:
        geoms[index].contype, geoms[index].conaffinity = FOOT_CONTYPE, FOOT_CONAFFINITY
    for index in others:
        geoms[index].contype, geoms[index].conaffinity = 0, 0
    silenced = {geoms[index].name for index in others} - {""}
    for pair in list(spec.pairs):
        if {pair.geomname1, pair.geomname2} & silenced:
            spec.delete(pair)


def set_cone(spec: mujoco.MjSpec, cone: str) -> None:
    """Give `spec` friction cones of kind `cone` ("pyramidal" or "elliptic"), in place.

    Raises:
      ValueError: an unknown cone.
    """
    if cone not in CONES:
        raise ValueError(f"unknown cone {cone!r}; known: {', '.join(CONES)}")
    spec.option.cone = getattr(mujoco.mjtCone, f"mjCONE_{cone.upper()}")


def set_servo_gains(spec: mujoco.MjSpec, kp: float, kd: float) -> None:
    """Give every position servo of `spec` (an affine-biased actuator: force = kp (target − q)
    − kd q̇) the gain `kp` (N m/rad) and damping `kd` (N m s/rad), in place; force ranges stay.

    Raises:
      ValueError: a gain that is not finite and > 0 or a damping below 0, or an actuator that is
        no position servo (torque motors take the robot preset's kp, kd: the PD quadcos closes).
    """
    if not (0 < kp < float("inf") and 0 <= kd < float("inf")):
        raise ValueError(f"servo gains must be finite, kp > 0 and kd >= 0; got kp {kp}, kd {kd}")
    for actuator in spec.actuators:
        servo = actuator.biastype == mujoco.mjtBias.mjBIAS_AFFINE and actuator.biasprm[1] < 0
        if not servo:
            raise ValueError(
                f"servo gains apply to position actuators; actuator {actuator.name or '(unnamed)'}"
                " is a torque motor (its PD gains: the robot preset's kp, kd)"
            )
        actuator.gainprm[0] = kp
        actuator.biasprm[1], actuator.biasprm[2] = -kp, -kd


def _is_visual(geom: mujoco.MjsGeom) -> bool:
    if geom.type == mujoco.mjtGeom.mjGEOM_MESH:
        return True
    return geom.group == 2 and geom.contype == 0 and geom.conaffinity == 0


def _adds_mass(spec: mujoco.MjSpec, geom: mujoco.MjsGeom) -> bool:
    """Whether the compiler would take part of the body's mass and inertia from `geom`."""
    from_geoms = spec.compiler.inertiafromgeom
    if from_geoms == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE:
        return False
    if from_geoms == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_AUTO and (
        geom.parent.explicitinertial or geom.parent == spec.worldbody
    ):
        return False
    low, high = spec.compiler.inertiagrouprange
    if not low <= geom.group <= high:
        return False
    return geom.mass > 0 if not math.isnan(geom.mass) else geom.density > 0


def _strip_image_textures(spec: mujoco.MjSpec) -> None:
    files = [texture for texture in spec.textures if texture.file or any(texture.cubefiles)]
    removed_textures = {texture.name for texture in files}
    for texture in files:
        spec.delete(texture)
    materials = [m for m in spec.materials if removed_textures & set(m.textures)]
    removed_materials = {material.name for material in materials}
    for material in materials:
        spec.delete(material)
    for element in (*spec.geoms, *spec.sites, *spec.tendons):
        if element.material in removed_materials:
            element.material = ""


def _geom_index(geoms: list[mujoco.MjsGeom], foot: str | int) -> int:
    if isinstance(foot, str):
        matches = [index for index, geom in enumerate(geoms) if foot and geom.name == foot]
        if not matches:
            raise ValueError(f"no geom named {foot!r}")
        return matches[0]
    try:
        index = operator.index(foot)
    except TypeError:
        index = None
    if isinstance(foot, bool) or index is None or not 0 <= index < len(geoms):
        raise ValueError(
            f"foot geom {foot!r} is neither a geom name nor an index below {len(geoms)}"
        )
    return index


def _label(geoms: list[mujoco.MjsGeom], index: int) -> str:
    return f"{geoms[index].name!r}" if geoms[index].name else f"#{index}"
