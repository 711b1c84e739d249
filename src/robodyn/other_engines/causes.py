"""Name why an engine's body or joint differs from robodyn's, in one line, and the option that removes it.

Pure functions of the two readings and of what the file declares; :mod:`robodyn.other_engines.compare` measures
each cause's effect on M, C v and G by applying it to robodyn's copy of the model.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from robodyn.other_engines.reading import DEFAULT, Array, BodyInertia, JointReading

# A diagonalisation keeps the principal moments to float32-like precision (PyBullet: ~1e-6 relative);
# below this band two inertias with equal moments differ only by their orientation.
DIAGONALISATION_RTOL = 1e-4


# Principal moments a <= b <= c are physically valid when a >= 0 and a + b >= c; within this fraction of c, a file's
# rounding (a thin rod's 0, I, I written to 6 digits), not an invalid inertia.
VALIDITY_RTOL = 1e-9


@dataclass(frozen=True)
class FileLinks:
    """What the URDF says of its links: those without ``<inertial>``, with mass 0, with an invalid inertia.

    ``invalid``: link -> its principal moments [kg m^2] where one is negative or they break the triangle
    inequality (Drake substitutes such an inertia; MuJoCo refuses it).
    """

    no_inertial: frozenset[str]
    zero_mass: frozenset[str]
    invalid: dict[str, Array] = field(default_factory=dict)


def invalid_moments(inertia: Array) -> Array | None:
    """The principal moments of ``inertia`` [kg m^2] if they are not physically valid, else None."""
    a, b, c = _moments(inertia)
    slack = VALIDITY_RTOL * max(abs(c), 1e-300)
    return np.array([a, b, c]) if a < -slack or a + b < c - slack else None


@dataclass(frozen=True)
class Tolerances:
    """Absolute tolerances: ``rtol`` times each quantity's scale over the robot (mass, length, inertia)."""

    mass: float
    length: float
    inertia: float


def _moments(inertia: Array) -> Array:
    return np.asarray(np.linalg.eigvalsh(0.5 * (inertia + inertia.T)), dtype=float)


def _is_diagonal(inertia: Array, tol: float) -> bool:
    return bool(np.abs(inertia - np.diag(np.diag(inertia))).max() <= tol)


def body_cause(
    engine: str, reading: str, mine: BodyInertia, theirs: BodyInertia, links: FileLinks, tol: Tolerances
) -> tuple[str, str | None] | None:
    """(what differs and why, the option that removes it or None) for one moving body, or None if they agree."""
    dm = theirs.mass - mine.mass
    moved = float(np.abs(theirs.com - mine.com).max())
    dI = float(np.abs(theirs.inertia - mine.inertia).max())
    if abs(dm) <= tol.mass and moved <= tol.length and dI <= tol.inertia:
        return None
    merged = f" (with {', '.join(mine.links[1:])} merged into {mine.links[0]})" if len(mine.links) > 1 else ""
    sizes = f"robodyn {mine.mass:.6g} kg, {engine} {theirs.mass:.6g} kg"
    lacking = [link for link in mine.links if link in links.no_inertial]
    zero = [link for link in mine.links if link in links.zero_mass]
    if abs(dm) > tol.mass and lacking:
        how = {"pybullet": "its default 1 kg", "mujoco": "a mass from its geometry"}.get(engine, "a mass")
        option = 'inertiafromgeom="false"' if engine == "mujoco" and reading == DEFAULT else None
        return f"no <inertial> on {', '.join(lacking)}: {engine} gives it {how} ({sizes})", option
    if abs(dm) > tol.mass and zero:
        return f"zero-mass link {', '.join(zero)}: {engine} gives it a mass ({sizes})", None
    if abs(dm) > tol.mass:
        return f"mass read differently{merged} ({sizes})", None
    if moved > tol.length:
        return f"centre of mass read differently{merged} (moved by {moved:.3g} m)", None
    broken = [link for link in mine.links if link in links.invalid]
    if broken:
        moments = ", ".join(f"{m:.3g}" for m in links.invalid[broken[0]])
        return (
            f"physically invalid inertia of {broken[0]} in the file (principal moments {moments} kg m^2): "
            f"{engine} replaces it{merged}",
            None,
        )
    return _inertia_cause(engine, reading, mine.inertia, theirs.inertia, tol.inertia, merged)


def _inertia_cause(
    engine: str, reading: str, mine: Array, theirs: Array, tol: float, merged: str
) -> tuple[str, str | None]:
    scale = float(np.abs(_moments(mine)).max()) or 1.0
    moments = float(np.abs(_moments(theirs) - _moments(mine)).max())
    whole = float(np.abs(theirs - mine).max())
    if whole <= DIAGONALISATION_RTOL * scale:
        return (
            f"a diagonalisation{merged}: {engine} stores principal moments and axes, "
            f"giving the inertia back to {whole / scale:.1e} relative",
            None,
        )
    if _is_diagonal(theirs, tol) and not _is_diagonal(mine, tol):
        if float(np.abs(theirs - np.diag(np.diag(mine))).max()) <= tol:
            return f"inertia's off-diagonal terms dropped{merged}", None
        if moments <= DIAGONALISATION_RTOL * scale:
            return f"inertia rotation dropped{merged}: {engine} keeps the principal moments in the link's axes", None
    if moments <= DIAGONALISATION_RTOL * scale:
        return f"inertia rotated differently{merged} (same principal moments)", None
    if engine == "pybullet" and reading == DEFAULT:
        return f"inertia taken from the collision shape{merged}", "flags=URDF_USE_INERTIA_FROM_FILE"
    if engine == "mujoco" and reading == DEFAULT:
        return f"inertia changed by the URDF compiler{merged}", 'fusestatic="false" balanceinertia="false"'
    return f"rotational inertia read differently{merged} (moments differ by {moments / scale:.1e} relative)", None


def joint_causes(engine: str, kind: str, mine: JointReading, theirs: JointReading) -> list[tuple[str, str | None]]:
    """Each way one joint (``kind``: revolute, prismatic, continuous) differs.

    Its axis, position limits, damping, effort and velocity limits, friction and armature.
    """
    unit = "m" if kind == "prismatic" else "rad"
    damping, rotor = ("N s/m", "kg") if kind == "prismatic" else ("N m s/rad", "kg m^2")
    found: list[tuple[str, str | None]] = []
    if float(np.abs(theirs.axis / np.linalg.norm(theirs.axis) - mine.axis).max()) > 1e-9:
        found.append((f"axis read differently: robodyn {_vec(mine.axis)}, {engine} {_vec(theirs.axis)}", None))
    if kind != "continuous" and not (_same(mine.lower, theirs.lower) and _same(mine.upper, theirs.upper)):
        found.append(
            (
                f"limits read differently: robodyn [{mine.lower:.6g}, {mine.upper:.6g}] {unit}, "
                f"{engine} {_range(theirs, unit)} (no effect on M, C v, G; acts in simulation)",
                None,
            )
        )
    if not _same(mine.damping, theirs.damping):
        found.append(
            (
                f"damping read differently: robodyn {mine.damping:.6g} {damping}, "
                f"{engine} {theirs.damping:.6g} {damping} (no effect on M, C v, G; acts in simulation)",
                None,
            )
        )
    found += _limit_causes(engine, kind, mine, theirs)
    if not _same(mine.armature, theirs.armature):
        option = {
            "mujoco": "giving MuJoCo the armature (<joint armature=...> in MJCF)",
            "drake": "giving Drake the rotor (<drake:rotor_inertia> and <drake:gear_ratio> in a <transmission>)",
        }.get(engine)
        found.append(
            (
                f"armature: robodyn {mine.armature:.6g} {rotor} (SRDF <rotor_params>), {engine} "
                f"{theirs.armature:.6g} {rotor}" + (" (PyBullet has no armature)" if engine == "pybullet" else ""),
                option,
            )
        )
    return found


def _limit_causes(engine: str, kind: str, mine: JointReading, theirs: JointReading) -> list[tuple[str, str | None]]:
    """Effort and velocity limits (where the engine holds such a limit at all) and friction."""
    force, speed = ("N", "m/s") if kind == "prismatic" else ("N m", "rad/s")
    found: list[tuple[str, str | None]] = []
    for what, unit, a, b in (
        ("effort limit", force, mine.effort, theirs.effort),
        ("velocity limit", speed, mine.velocity, theirs.velocity),
    ):
        if b is not None and not _same(np.nan if a is None else a, b):
            found.append(
                (
                    f"{what} read differently: robodyn {_bound(a, unit)}, {engine} {_bound(b, unit)} "
                    "(no effect on M, C v, G; caps the motion in simulation)",
                    None,
                )
            )
    if not _same(mine.friction, theirs.friction):
        why = " (Drake's MultibodyPlant has no joint friction: its parser drops it)" if engine == "drake" else ""
        found.append(
            (
                f"friction read differently: robodyn {mine.friction:.6g} {force}, "
                f"{engine} {theirs.friction:.6g} {force}{why} (no effect on M, C v, G; acts in simulation)",
                None,
            )
        )
    return found


def _bound(value: float | None, unit: str) -> str:
    return "none" if value is None or np.isnan(value) else f"{value:.6g} {unit}"


def _same(a: float, b: float) -> bool:
    if np.isnan(a) or np.isnan(b):
        return bool(np.isnan(a) and np.isnan(b))
    return abs(a - b) <= 1e-9 * max(1.0, abs(a))


def _vec(x: Array) -> str:
    return "(" + ", ".join(f"{v:.6g}" for v in x) + ")"


def _range(joint: JointReading, unit: str) -> str:
    if np.isnan(joint.lower):
        return "none"
    return f"[{joint.lower:.6g}, {joint.upper:.6g}] {unit}"
