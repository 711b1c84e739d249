"""Robots shipped by the ``example-robot-data`` package, reachable by name.

The PyPI wheel of example-robot-data carries URDF, SRDF and meshes under
``cmeel.prefix/share/example-robot-data/robots`` but no Python loader, so robodyn indexes
that folder itself:

* every URDF is reachable by its file stem (``talos_reduced``, ``ur5_robot``...);
* the short names of example-robot-data's own loader (``talos``, ``ur5``, ``hyq``...) are
  aliases, and each comes with the SRDF that loader pairs with it. That pairing matters:
  ``talos_reduced.urdf`` has no ``talos_reduced.srdf``; its rotor parameters (armature
  0.1 kg m^2 on every arm, leg and torso joint) live in ``talos.srdf``.

Robots that the loader mounts on a free flyer (legged robots, humanoids, drones) carry
``free_flyer_hint=True``; robodyn still loads them fixed-base unless ``free_flyer=True``
is asked for, and ``robodyn info`` says so.

:func:`not_loadable` lists the robots of the package that robodyn cannot load, with why.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from robodyn.errors import ModelError, UnknownModelError
from robodyn.model.files import (
    BUILTIN_NAMES,
    VARIANT_NAMES,
    ModelSource,
    find_srdf,
    looks_like_path,
    models_dir,
    not_urdf,
    opening_line,
    robots_dir,
)
from robodyn.registry import Registry


@dataclass(frozen=True)
class LoaderEntry:
    """How example-robot-data's loader builds one named robot."""

    urdf: str  # path under robots/, e.g. "talos_data/robots/talos_reduced.urdf"
    srdf: str | None  # path under robots/, or None
    free_flyer: bool


def _e(urdf: str, srdf: str | None = None, free_flyer: bool = False) -> LoaderEntry:
    return LoaderEntry(urdf, srdf, free_flyer)


_TALOS_SRDF = "talos_data/srdf/talos.srdf"

# example-robot-data's loader names (robots_loader.ROBOTS, version 4.x-6.x), plus the
# robots added to the data since then under their folder's name.
LOADERS: dict[str, LoaderEntry] = {
    "a1": _e("a1_description/urdf/a1.urdf", "a1_description/srdf/a1.srdf", True),
    "alex": _e("alex_description/urdf/alex_nub_hands.urdf", "alex_description/srdf/alex_nub_hands.srdf"),
    "alexander": _e(
        "alexander_description/urdf/alexander_v1.lowerBodyOnly.urdf", "alexander_description/srdf/alexander.srdf", True
    ),
    "allegro_left_hand": _e("allegro_hand_description/urdf/allegro_left_hand.urdf"),
    "allegro_right_hand": _e("allegro_hand_description/urdf/allegro_right_hand.urdf"),
    "anymal": _e(
        "anymal_b_simple_description/robots/anymal.urdf", "anymal_b_simple_description/srdf/anymal.srdf", True
    ),
    "anymal_c": _e(
        "anymal_c_simple_description/urdf/anymal.urdf", "anymal_c_simple_description/srdf/anymal.srdf", True
    ),
    "anymal_kinova": _e(
        "anymal_b_simple_description/robots/anymal-kinova.urdf",
        "anymal_b_simple_description/srdf/anymal-kinova.srdf",
        True,
    ),
    "asr_twodof": _e("asr_twodof_description/urdf/TwoDofs.urdf"),
    "b1": _e("b1_description/urdf/b1.urdf", "b1_description/srdf/b1.srdf", True),
    "b1_z1": _e("b1_description/urdf/b1-z1.urdf", "b1_description/srdf/b1-z1.srdf", True),
    "baxter": _e("baxter_description/urdf/baxter.urdf"),
    "bolt": _e("bolt_description/robots/bolt.urdf", "bolt_description/srdf/bolt.srdf", True),
    "borinot": _e(
        "borinot_description/urdf/borinot_flying_arm_2.urdf", "borinot_description/srdf/borinot_flying_arm_2.srdf", True
    ),
    "centauro": _e("centauro_description/urdf/centauro.urdf", "centauro_description/srdf/centauro.srdf", True),
    "double_pendulum": _e("double_pendulum_description/urdf/double_pendulum.urdf"),
    "double_pendulum_continuous": _e("double_pendulum_description/urdf/double_pendulum_continuous.urdf"),
    "double_pendulum_simple": _e("double_pendulum_description/urdf/double_pendulum_simple.urdf"),
    "finger_edu": _e("finger_edu_description/robots/finger_edu.urdf", "finger_edu_description/srdf/finger_edu.srdf"),
    "g1": _e("g1_description/urdf/g1_29dof_rev_1_0.urdf", None, True),
    "g1_with_hand": _e("g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf", None, True),
    "go1": _e("go1_description/urdf/go1.urdf", "go1_description/srdf/go1.srdf", True),
    "go2": _e("go2_description/urdf/go2.urdf", "go2_description/srdf/go2.srdf", True),
    "hector": _e("hector_description/robots/quadrotor_base.urdf", None, True),
    "hextilt": _e(
        "hextilt_description/urdf/hextilt_flying_arm_5.urdf", "hextilt_description/srdf/hextilt_flying_arm_5.srdf", True
    ),
    "human": _e("human_description/robots/human.urdf", None, True),
    "hyq": _e("hyq_description/robots/hyq_no_sensors.urdf", "hyq_description/srdf/hyq.srdf", True),
    "icub": _e("icub_description/robots/icub.urdf", "icub_description/srdf/icub.srdf", True),
    "icub_reduced": _e("icub_description/robots/icub_reduced.urdf", "icub_description/srdf/icub.srdf", True),
    "iris": _e("iris_description/robots/iris_simple.urdf", None, True),
    "kinova": _e("kinova_description/robots/kinova.urdf", "kinova_description/srdf/kinova.srdf"),
    "laikago": _e("laikago_description/urdf/laikago.urdf", None, True),
    "panda": _e("panda_description/urdf/panda.urdf", "panda_description/srdf/panda.srdf"),
    "panda_collision": _e("panda_description/urdf/panda_collision.urdf", "panda_description/srdf/panda.srdf"),
    "pr2": _e("pr2_description/urdf/pr2.urdf", "pr2_description/srdf/pr2.srdf"),
    "quadruped": _e("quadruped_description/urdf/quadruped.urdf", None, True),
    "romeo": _e("romeo_description/urdf/romeo.urdf", None, True),
    "romeo_small": _e("romeo_description/urdf/romeo_small.urdf", "romeo_description/srdf/romeo_small.srdf", True),
    "simple_humanoid": _e(
        "simple_humanoid_description/urdf/simple_humanoid.urdf",
        "simple_humanoid_description/srdf/simple_humanoid.srdf",
        True,
    ),
    "simple_humanoid_classical": _e(
        "simple_humanoid_description/urdf/simple_humanoid_classical.urdf",
        "simple_humanoid_description/srdf/simple_humanoid_classical.srdf",
        True,
    ),
    "so100": _e("so_arm_description/urdf/so100.urdf"),
    "so101": _e("so_arm_description/urdf/so101.urdf"),
    "solo8": _e("solo_description/robots/solo.urdf", "solo_description/srdf/solo.srdf", True),
    "solo12": _e("solo_description/robots/solo12.urdf", "solo_description/srdf/solo.srdf", True),
    "talos": _e("talos_data/robots/talos_reduced.urdf", _TALOS_SRDF, True),
    "talos_box": _e("talos_data/robots/talos_reduced_box.urdf", _TALOS_SRDF, True),
    "talos_corrected": _e("talos_data/robots/talos_reduced_corrected.urdf", _TALOS_SRDF, True),
    "talos_arm": _e("talos_data/robots/talos_left_arm.urdf", _TALOS_SRDF),
    "talos_full": _e("talos_data/robots/talos_full_v2.urdf", _TALOS_SRDF, True),
    "talos_full_box": _e("talos_data/robots/talos_full_v2_box.urdf", _TALOS_SRDF, True),
    "tiago": _e("tiago_description/robots/tiago.urdf"),
    "tiago_dual": _e("tiago_description/robots/tiago_dual.urdf"),
    "tiago_no_hand": _e("tiago_description/robots/tiago_no_hand.urdf"),
    "tiago_pro": _e("tiago_pro_description/robots/tiago_pro.urdf"),
    "ur3": _e("ur_description/urdf/ur3_robot.urdf"),
    "ur3_gripper": _e("ur_description/urdf/ur3_gripper.urdf", "ur_description/srdf/ur3_gripper.srdf"),
    "ur3_limited": _e("ur_description/urdf/ur3_joint_limited_robot.urdf"),
    "ur5": _e("ur_description/urdf/ur5_robot.urdf", "ur_description/srdf/ur5.srdf"),
    "ur5_gripper": _e("ur_description/urdf/ur5_gripper.urdf", "ur_description/srdf/ur5_gripper.srdf"),
    "ur5_limited": _e(
        "ur_description/urdf/ur5_joint_limited_robot.urdf", "ur_description/srdf/ur5_joint_limited_robot.srdf"
    ),
    "ur10": _e("ur_description/urdf/ur10_robot.urdf"),
    "ur10_limited": _e("ur_description/urdf/ur10_joint_limited_robot.urdf"),
    "xarm7": _e("xarm_description/urdf/xarm7.urdf", "xarm_description/srdf/xarm7.srdf"),
    "z1": _e("z1_description/urdf/z1.urdf", "z1_description/srdf/z1.srdf"),
}

# Robots of the package robodyn cannot load, with the reason (checked by tests/test_robot_library.py).
NOT_LOADABLE: dict[str, str] = {
    "cassie": "ships only SDF files (cassie_description/robots/cassie.sdf) and robodyn reads URDF; "
    "Pinocchio's SDF parser needs a build with sdformat, which the PyPI wheel pin 4.1 lacks",
    "ur3.urdf": "ur_description/urdf/ur3.urdf is an empty xacro stub (<robot> with no name and no link); "
    "the UR3 itself loads as 'ur3' (ur3_robot.urdf)",
}


def _stem_name(urdf: Path, stems: dict[str, int]) -> str:
    # Two packages ship an "anymal.urdf": disambiguate with the package folder.
    if stems[urdf.stem] > 1:
        return urdf.parent.parent.name.removesuffix("_description").removesuffix("_simple")
    return urdf.stem


def _is_stub(urdf: Path) -> bool:
    return urdf.name in NOT_LOADABLE


@lru_cache(maxsize=1)
def sources() -> dict[str, ModelSource]:
    """Name -> :class:`ModelSource` for every URDF in example-robot-data (empty if absent).

    Loader names (``talos``, ``ur5``...) come first with their SRDF; every other URDF
    follows under its file stem, paired with an SRDF of the same stem if one exists.
    """
    folder = robots_dir()
    if folder is None:
        return {}
    table: dict[str, ModelSource] = {}
    by_urdf: dict[Path, LoaderEntry] = {}
    for name, entry in sorted(LOADERS.items()):
        urdf = folder / entry.urdf
        if not urdf.is_file():
            continue
        srdf = folder / entry.srdf if entry.srdf is not None and (folder / entry.srdf).is_file() else None
        table[name] = ModelSource(urdf, srdf, f"example-robot-data {entry.urdf}", free_flyer_hint=entry.free_flyer)
        by_urdf.setdefault(urdf, entry)
    urdfs = [u for u in sorted(folder.glob("*/*/*.urdf")) if not _is_stub(u)]
    stems: dict[str, int] = {}
    for urdf in urdfs:
        stems[urdf.stem] = stems.get(urdf.stem, 0) + 1
    for urdf in urdfs:
        name = _stem_name(urdf, stems)
        if name in table:
            continue
        known = by_urdf.get(urdf)
        if known is not None:  # same file as a loader name: same SRDF and free-flyer hint
            srdf = folder / known.srdf if known.srdf is not None else None
            hint = known.free_flyer
        else:
            srdf, hint = find_srdf(urdf), False
        rel = urdf.relative_to(folder).as_posix()
        table[name] = ModelSource(urdf, srdf, f"example-robot-data {rel}", free_flyer_hint=hint)
    return table


def loader_names() -> tuple[str, ...]:
    """The example-robot-data loader names whose files are installed, sorted."""
    available = sources()
    return tuple(name for name in sorted(LOADERS) if name in available)


def distinct_robots() -> tuple[str, ...]:
    """One name per distinct URDF file of the package (loader name where there is one), sorted."""
    seen: dict[Path, str] = {}
    for name in (*loader_names(), *sorted(sources())):
        urdf = sources()[name].urdf
        seen.setdefault(urdf, name)
    return tuple(sorted(seen.values()))


def not_loadable() -> dict[str, str]:
    """Robots (or files) of example-robot-data that robodyn cannot load -> the reason."""
    return dict(NOT_LOADABLE)


# A built-in's description is its URDF's opening line (files.opening_line); the variants' are here.
_DESCRIPTIONS = {
    "geared_arm_rotor": "geared_arm with the rotor as its own body, coupled to the link by a mimic joint",
    "cart_pole_point_bob": "cart_pole with the pole's mass as a point bob at its centre of mass",
}


def _builtin_sources() -> Registry[ModelSource]:
    registry: Registry[ModelSource] = Registry("model")
    for folder, names in ((models_dir(), BUILTIN_NAMES), (models_dir() / "variants", VARIANT_NAMES)):
        for name in names:
            urdf = folder / f"{name}.urdf"
            if not urdf.is_file():
                continue
            srdf = folder / f"{name}.srdf"
            description = _DESCRIPTIONS.get(name) or opening_line(urdf)
            registry.register(name, ModelSource(urdf, srdf if srdf.is_file() else None, description))
    return registry


def model_sources() -> Registry[ModelSource]:
    """Every model reachable by name: the built-ins and variants, then example-robot-data."""
    registry = _builtin_sources()
    for name, source in sources().items():
        if name not in registry:
            registry.register(name, source)
    return registry


def _is_file(name: str | Path) -> bool:
    """True when ``name`` is an existing file; False also where the system cannot take it as a path (too long)."""
    try:
        return Path(name).is_file()
    except OSError:  # ENAMETOOLONG and the like: a name, not a file
        return False


def resolve(name_or_path: str | Path, *, srdf: str | Path | None = None) -> ModelSource:
    """Turn a built-in or library name, or a URDF path, into a :class:`ModelSource`.

    A name that is no model's but an existing file's (``mybot`` in the current folder) is that file.
    """
    sources = model_sources()
    if looks_like_path(name_or_path) or (str(name_or_path) not in sources and _is_file(name_or_path)):
        urdf = Path(name_or_path)
        refused = not_urdf(urdf)
        if refused is not None and urdf.is_file():
            raise ModelError(refused, path=urdf)
        if urdf.is_dir():
            raise ModelError("is a directory (expected a path to a .urdf file or a model name)", path=urdf)
        if urdf.exists() and not urdf.is_file():
            raise ModelError("is not a regular file (expected a path to a .urdf file or a model name)", path=urdf)
        if not urdf.is_file():
            raise ModelError("no such URDF file (expected a path to a .urdf file or a model name)", path=urdf)
        found = Path(srdf) if srdf is not None else find_srdf(urdf)
        return ModelSource(urdf, found, f"URDF file {urdf.name}")
    if str(name_or_path) not in sources:
        raise UnknownModelError(str(name_or_path), sources.names())
    source = sources.get(str(name_or_path))
    if srdf is not None:
        return ModelSource(source.urdf, Path(srdf), source.description, source.free_flyer_hint)
    return source
