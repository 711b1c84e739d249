"""``robodyn.against(robot, "mujoco")``: does another engine read this URDF as Pinocchio does, and if not, why.

For each engine and each reading (its defaults, and the option that makes it trust the file) the engine's
bodies and joints are compared with robodyn's, then M(q), C(q, v) v and G(q) at seeded states. Each body or
joint that differs is a candidate cause; applied alone to a copy of robodyn's model (that body's inertia, that
joint's armature replaced by the engine's), it gives the cause's effect on M, C v and G. All of them applied
together must reproduce the engine: whatever is left is reported as unexplained.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from robodyn import dynamics
from robodyn.errors import EngineRefusedError, InputError, UnknownNameError
from robodyn.model.files import read_xml
from robodyn.other_engines import causes as names
from robodyn.other_engines.reading import (
    DEFAULT,
    ENGINES,
    TRUSTED,
    Array,
    BodyInertia,
    EngineReading,
    JointReading,
    require,
)
from robodyn.other_engines.report import AgainstReport, Cause, Comparison
from robodyn.robot import Robot

_MODULES = {"mujoco": "mujoco", "pybullet": "pybullet", "drake": "pydrake"}
QUANTITIES = ("M", "Cv", "G")
# A C v or G below this fraction of the robot's torque scale (M v^2, m g l) is zero up to round-off: round-off is
# ~1e-16 of the terms it is summed from (~that scale), so measured against ZERO_FLOOR times it, it stays ~1e-10
# relative, under the default rtol 1e-9, while a real C v or G (above it) is measured against itself.
ZERO_FLOOR = 1e-6
NO_LIMIT = 1e300  # [N m | rad/s] a bound at least this large is Pinocchio's mark of no limit (float max)


def against(
    robot: Robot,
    engines: str | Sequence[str] = "mujoco",
    *,
    samples: int = 20,
    seed: int = 0,
    rtol: float = 1e-9,
    readings: Sequence[str] = (DEFAULT, TRUSTED),
) -> AgainstReport:
    """Compare robodyn's reading of ``robot``'s URDF with each engine's, naming the cause of each difference.

    Args:
        robot: a robot loaded from a URDF (built-in, example-robot-data or a path), fixed base or with
            ``free_flyer=True`` (mapped to each engine's floating base: :mod:`robodyn.other_engines.floating`).
        engines: ``"mujoco"``, ``"pybullet"``, ``"drake"`` or a sequence of them.
        samples: number of seeded random states at which M, C v and G are compared.
        seed: seed of those states.
        rtol: relative tolerance, against each quantity's largest entry over the states (and, for bodies,
            the largest mass [kg], centre-of-mass distance [m] and inertia entry [kg m^2] of the robot).
        readings: ``"default"`` (the engine's defaults) and/or ``"trusted"`` (the option that trusts the file).

    Raises:
        UnknownNameError: an engine that is not one of mujoco, pybullet, drake.
        MissingDependencyError: an engine that is not installed (the message names the extra).
        InputError: a robot without a URDF file or without a moving joint, or with a joint other than revolute,
            continuous, prismatic (and a free flyer at its root); a free flyer compared with PyBullet.
    """
    start = time.perf_counter()
    chosen = (engines,) if isinstance(engines, str) else tuple(engines)
    for engine in chosen:
        if engine not in ENGINES:
            raise UnknownNameError("engine", engine, ENGINES)
        require(_MODULES[engine], engine)
    _require_tree(robot, chosen)
    rng = np.random.default_rng(seed)
    states = [robot.random_state(rng) for _ in range(samples)]
    mine = _evaluate(robot.model, robot, states)
    comparisons = tuple(
        _compare(robot, engine, reading, states, mine, rtol)
        for engine in chosen
        for reading in readings
        if engine != "drake" or reading == DEFAULT  # Drake has no option that trusts the file more
    )
    return AgainstReport(robot.name, rtol, samples, seed, comparisons, time.perf_counter() - start)


def _require_tree(robot: Robot, engines: Sequence[str]) -> None:
    if robot.urdf_path is None:
        raise InputError(f"{robot.name}: --against reads the robot's URDF file, and this robot has none")
    if robot.nv == 0:
        raise InputError(
            f"{robot.name}: no moving joint: --against compares M, C v and G, which a robot without one does not "
            "have; expected a URDF with a revolute, continuous or prismatic joint (or --free-flyer)"
        )
    odd = [j.name for j in robot.joints[1 if free_flyer(robot) else 0 :] if j.nv != 1]
    if odd:
        raise InputError(
            f"{robot.name}: joint {odd[0]} has {robot.joint(odd[0]).nv} velocities; --against compares robots whose "
            "joints are revolute, continuous or prismatic, on a fixed base or a free flyer (--free-flyer)"
        )
    if free_flyer(robot) and "pybullet" in engines:
        raise InputError(
            f"{robot.name}: --against pybullet compares fixed-base robots only: PyBullet 3.2.7 gives no floating "
            "base's C v and G (calculateInverseDynamics fails on it; with flags=1 its mass matrix is not symmetric "
            "and the call corrupts memory); drop --free-flyer, or compare with mujoco or drake"
        )


def free_flyer(robot: Robot) -> bool:
    """Whether ``robot``'s root is Pinocchio's free flyer (robodyn's ``--free-flyer``)."""
    return bool(robot.joints) and robot.joints[0].kind == "JointModelFreeFlyer"


def _hinges(robot: Robot) -> tuple[str, ...]:
    """The joints with one velocity (revolute, continuous, prismatic): all but a free flyer."""
    return robot.joint_names[1:] if free_flyer(robot) else robot.joint_names


def _kind(robot: Robot, name: str) -> str:
    joint = robot.joint(name)
    return "continuous" if joint.nq == 2 else "prismatic" if joint.kind.startswith("JointModelP") else "revolute"


def _scalars(robot: Robot, q: Array) -> Array:
    """One coordinate per one-velocity joint: a continuous joint's (cos, sin) becomes its angle [rad]."""
    out = []
    for name in _hinges(robot):
        j = robot.joint(name)
        out.append(np.arctan2(q[j.idx_q + 1], q[j.idx_q]) if j.nq == 2 else q[j.idx_q])
    return np.array(out)


def _evaluate(model: Any, robot: Robot, states: list[tuple[Array, Array]]) -> dict[str, Array]:
    """M, C v, G of ``model`` (robodyn's or a patched copy) at ``states``, stacked over the states."""
    data = model.createData()
    out: dict[str, list[Array]] = {k: [] for k in QUANTITIES}
    for q, v in states:
        G = dynamics.gravity(model, data, q)
        out["M"].append(dynamics.mass_matrix(model, data, q))
        out["Cv"].append(dynamics.nonlinear_effects(model, data, q, v) - G)
        out["G"].append(G)
    return {k: np.array(x) for k, x in out.items()}


def _relative(a: dict[str, Array], b: dict[str, Array], scale: dict[str, float]) -> dict[str, float]:
    return {k: float(np.abs(a[k] - b[k]).max() / scale[k]) for k in QUANTITIES}


def _effect(a: dict[str, Array], b: dict[str, Array], scale: dict[str, float], rtol: float) -> dict[str, float]:
    """A cause's effect on M, C v, G: 0 where it is within ``rtol`` (rounding, not the cause)."""
    return {k: (x if x > rtol else 0.0) for k, x in _relative(a, b, scale).items()}


def _read(robot: Robot, engine: str, reading: str) -> EngineReading:
    from robodyn.model.files import package_dirs

    assert robot.urdf_path is not None  # checked by _require_tree
    dirs = package_dirs(robot.urdf_path)
    free = free_flyer(robot)
    if engine == "mujoco":
        from robodyn.other_engines import mujoco_side

        return mujoco_side.read(robot.urdf_path, dirs, reading, free_flyer=free)
    if engine == "pybullet":
        from robodyn.other_engines import pybullet_side

        return pybullet_side.read(robot.urdf_path, dirs, reading)
    from robodyn.other_engines import drake_side

    return drake_side.read(robot.urdf_path, dirs, reading, root_link=_root_link(robot), free_flyer=free)


def _root_link(robot: Robot) -> str:
    """The URDF's root link: the first body frame on the universe (fixed base) or on the free flyer."""
    model, root = robot.model, 1 if free_flyer(robot) else 0
    return next(str(f.name) for f in model.frames if f.parentJoint == root and str(f.type).endswith("BODY"))


def _compare(
    robot: Robot, engine: str, reading: str, states: list[tuple[Array, Array]], mine: dict[str, Array], rtol: float
) -> Comparison:
    start = time.perf_counter()
    try:
        theirs = _read(robot, engine, reading)
    except EngineRefusedError as exc:
        return Comparison(engine, "", reading, "", {}, (), None, str(exc), time.perf_counter() - start)
    hinges = _hinges(robot)
    if set(theirs.names) != set(hinges):
        told = f"{engine} moves joints {sorted(theirs.names)}, robodyn {sorted(hinges)}"
        return Comparison(
            engine, theirs.version, reading, theirs.option, {}, (), None, told, time.perf_counter() - start
        )
    base = 6 if free_flyer(robot) else 0  # a free flyer's 6 velocities come first, in Pinocchio's coordinates
    within = [theirs.names.index(name) for name in hinges]
    order = list(range(base)) + [base + i for i in within]
    values: dict[str, list[Array]] = {k: [] for k in QUANTITIES}
    for q, v in states:
        head = q[:7] if base else q[:0]  # Pinocchio's free-flyer q: [x y z qx qy qz qw]
        engine_q = np.concatenate([head, _scalars(robot, q)[np.argsort(within)]])
        M, Cv, G = theirs.evaluate(engine_q, v[np.argsort(order)])
        for k, x in zip(QUANTITIES, (M[np.ix_(order, order)], Cv[order], G[order]), strict=True):
            values[k].append(x)
    engine_values = {k: np.array(x) for k, x in values.items()}
    scale = _scales(robot, mine, states)
    differences = _relative(engine_values, mine, scale)
    found, patched = _causes(robot, theirs, states, mine, scale, rtol)
    residual = _relative(engine_values, patched, scale)
    unexplained = residual if max(residual.values()) > rtol else None
    return Comparison(
        engine,
        theirs.version,
        reading,
        theirs.option,
        differences,
        tuple(found),
        unexplained,
        None,
        time.perf_counter() - start,
    )


def _scales(robot: Robot, mine: dict[str, Array], states: list[tuple[Array, Array]]) -> dict[str, float]:
    """What each quantity's differences are relative to: its largest entry over the states.

    For C v and G, at least ZERO_FLOOR times the robot's torque scale: the larger of M v^2 (what the states'
    speeds make) and m g l (its moving mass m, gravity g and its longest lever l, a joint's offset or a centre of
    mass's). A C v or G that is zero, or nearly, at every state (wheels spinning about their centres of mass;
    gravity along every axis) is then measured against the torques its sums are made of, not against its own
    round-off, which any engine's sums in another order differ from by 100 %.
    """
    model = robot.model
    m = float(np.abs(mine["M"]).max()) or 1.0
    speed = max((float(np.abs(v).max()) for _, v in states), default=1.0) or 1.0
    moving = range(1, model.njoints)
    mass = sum(float(model.inertias[j].mass) for j in moving)
    levers = [np.linalg.norm(model.inertias[j].lever) for j in moving]
    levers += [np.linalg.norm(model.jointPlacements[j].translation) for j in moving]
    lever = float(max(levers, default=0.0))
    gravity = float(np.linalg.norm(model.gravity.linear))
    floor = ZERO_FLOOR * max(m * speed**2, mass * gravity * lever)
    return {
        "M": m,
        "Cv": max(float(np.abs(mine["Cv"]).max()), floor) or 1.0,
        "G": max(float(np.abs(mine["G"]).max()), floor) or 1.0,
    }


def _causes(
    robot: Robot,
    theirs: EngineReading,
    states: list[tuple[Array, Array]],
    mine: dict[str, Array],
    scale: dict[str, float],
    rtol: float,
) -> tuple[list[Cause], dict[str, Array]]:
    """Each difference with its effect, and M, C v, G of robodyn's model with every difference applied."""
    bodies = robodyn_bodies(robot)
    tol = _tolerances(bodies, rtol)
    links = file_links(robot)
    everything = robot.model.copy()
    found, patched = [], False
    for name in robot.joint_names:
        j = robot.model.getJointId(name)
        said = names.body_cause(theirs.engine, theirs.reading, bodies[name], theirs.bodies[name], links, tol)
        if said is not None:
            patch = robot.model.copy()
            _set_inertia(patch, j, theirs.bodies[name])
            _set_inertia(everything, j, theirs.bodies[name])
            patched = True
            effect = _effect(_evaluate(patch, robot, states), mine, scale, rtol)
            found.append(Cause(f"{bodies[name].links[0]} ({name})", said[0], said[1], effect))
        if name not in theirs.joints:
            continue  # the free flyer: a body, with no axis, limits or armature
        joint = robot.joint(name)
        for what, option in names.joint_causes(
            theirs.engine, _kind(robot, name), robodyn_joint(robot, name), theirs.joints[name]
        ):
            effect = {k: 0.0 for k in QUANTITIES}
            if what.startswith("armature"):
                patch = robot.model.copy()
                patch.armature[joint.idx_v] = everything.armature[joint.idx_v] = theirs.joints[name].armature
                patched = True
                effect = _effect(_evaluate(patch, robot, states), mine, scale, rtol)
            found.append(Cause(name, what, option, effect))
    return found, _evaluate(everything, robot, states) if patched else mine


def _set_inertia(model: Any, joint: int, body: BodyInertia) -> None:
    import pinocchio as pin

    model.inertias[joint] = pin.Inertia(body.mass, body.com, body.inertia)


def robodyn_bodies(robot: Robot) -> dict[str, BodyInertia]:
    """Per moving joint, the inertia Pinocchio holds (its link and the links merged into it), in the link's frame."""
    model = robot.model
    out = {}
    for name in robot.joint_names:
        j = model.getJointId(name)
        links = tuple(str(f.name) for f in model.frames if f.parentJoint == j and str(f.type).endswith("BODY"))
        inertia = model.inertias[j]
        out[name] = BodyInertia(links, float(inertia.mass), np.array(inertia.lever), np.array(inertia.inertia))
    return out


def robodyn_joint(robot: Robot, name: str) -> JointReading:
    """The joint as Pinocchio holds it.

    Its axis in its link's frame, limits (nan on a continuous joint), damping, armature, effort and velocity
    limits (nan where none) and friction.
    """
    model = robot.model
    joint = robot.joint(name)
    axis = _axis(robot, name)
    lower, upper = np.nan, np.nan
    if joint.nq == 1:
        lower, upper = float(model.lowerPositionLimit[joint.idx_q]), float(model.upperPositionLimit[joint.idx_q])
    i = joint.idx_v
    return JointReading(
        axis,
        lower,
        upper,
        float(model.damping[i]),
        float(model.armature[i]),
        effort=_limit(model.effortLimit[i]),
        velocity=_limit(model.velocityLimit[i]),
        friction=float(model.friction[i]),
    )


def _limit(value: float) -> float:
    """A limit Pinocchio holds, nan where it holds none (an infinite or float-max bound)."""
    return float(value) if np.isfinite(value) and abs(value) < NO_LIMIT else np.nan


def _axis(robot: Robot, name: str) -> Array:
    """The unit axis the URDF gives ``name`` (robodyn's validated reading of the file)."""
    assert robot.urdf_path is not None  # checked by _require_tree
    return _file_axes(str(robot.urdf_path), robot.urdf_path.stat().st_mtime_ns).get(name, np.array([1.0, 0.0, 0.0]))


@functools.lru_cache(maxsize=8)
def _file_axes(urdf: str, _mtime_ns: int) -> dict[str, Array]:
    """Joint name -> unit axis, read once per file (and again if it changed)."""
    axes = {}
    for joint in read_xml(Path(urdf), "URDF").findall("joint"):
        element = joint.find("axis")
        axis = np.array([float(x) for x in element.get("xyz", "1 0 0").split()]) if element is not None else None
        if axis is None or not np.linalg.norm(axis) > 0:  # a fixed joint's axis may be (0, 0, 0): no direction
            axis = np.array([1.0, 0.0, 0.0])
        axes[str(joint.get("name"))] = axis / np.linalg.norm(axis)
    return axes


def file_links(robot: Robot) -> names.FileLinks:
    """The URDF's links without ``<inertial>``, those whose mass is 0 and those whose inertia is invalid."""
    assert robot.urdf_path is not None  # checked by _require_tree
    lacking, zero, invalid = set(), set(), {}
    for link in read_xml(robot.urdf_path, "URDF").findall("link"):
        mass = link.find("inertial/mass")
        inertia = link.find("inertial/inertia")
        if link.find("inertial") is None:
            lacking.add(str(link.get("name")))
        elif mass is not None and float(mass.get("value", "0")) == 0.0:
            zero.add(str(link.get("name")))
        if inertia is not None:
            i = {k: float(inertia.get(k, "0")) for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")}
            matrix = np.array(
                [[i["ixx"], i["ixy"], i["ixz"]], [i["ixy"], i["iyy"], i["iyz"]], [i["ixz"], i["iyz"], i["izz"]]]
            )
            moments = names.invalid_moments(matrix)
            if moments is not None:
                invalid[str(link.get("name"))] = moments
    return names.FileLinks(frozenset(lacking), frozenset(zero), invalid)


def _tolerances(bodies: dict[str, BodyInertia], rtol: float) -> names.Tolerances:
    mass = max((b.mass for b in bodies.values()), default=1.0) or 1.0
    length = max((float(np.abs(b.com).max()) for b in bodies.values()), default=1.0) or 1.0
    inertia = max((float(np.abs(b.inertia).max()) for b in bodies.values()), default=1.0) or 1.0
    return names.Tolerances(rtol * mass, rtol * length, rtol * inertia)
