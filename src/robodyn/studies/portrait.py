"""Phase portraits: the (q_j, v_j) plane of one joint, with the energy that orders it.

One joint moves; every other joint is held at a reference configuration (the neutral pose, or
the LQR's equilibrium when a region is drawn), so the plane is the phase plane of a one-degree-of-
freedom system whose energy is exact:

    E(q_j, v_j) = 1/2 M_jj(q) v_j^2 + V(q),  q = the reference with its j-th entry replaced by q_j,

with M from CRBA and V Pinocchio's potential energy (heights from the world frame) [J]. Its
equilibria are the zeros of G_j (refined by Brent's method from a scan), stable where dG_j/dq_j > 0
(a minimum of V). The separatrix is the level set through the highest unstable equilibrium: for a
pendulum, the homoclinic orbit that divides swinging from turning over.

The flow of the one-joint system, drawn as streamlines, is (q_j', v_j') = (v_j, a) with
a = -(dE/dq_j) / M_jj (energy is conserved along it, so it runs along the contours), dE/dq_j
by central differences on the grid.

A trajectory (of the full robot) is drawn by its j-th coordinate and velocity (a revolute
coordinate wrapped into the plotted turn, the line broken where it wraps); an LQR's estimated
region {e : e^T P e < rho} is drawn as its slice by the plane (the other error components zero):
an ellipse about the equilibrium. Only the numbers are computed here; ``robodyn.charts.portrait``
draws them and ``robodyn portrait`` writes the chart with its CSV and JSON.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import brentq

from robodyn.errors import InputError, UnknownNameError
from robodyn.robot import Robot

Array = NDArray[np.float64]

DEFAULT_RESOLUTION = 121  # grid points per axis: smooth contours, a CSV of ~15,000 rows
SCAN_POINTS = 2001  # samples of G_j on the range when looking for equilibria
SPEED_MARGIN = 1.3  # the speed axis reaches this multiple of the separatrix's (or the data's) top speed


@dataclass(frozen=True)
class Equilibrium:
    """A rest point of the one-joint system: q_j [rad | m], its energy V [J], and whether it is stable."""

    q: float
    energy: float
    stable: bool


@dataclass(frozen=True)
class Ellipse:
    """The slice {(dq, dv) : [dq dv] P2 [dq dv]^T < rho} of an LQR region, centred at (q0, 0)."""

    q0: float
    P2: Array
    rho: float

    def outline(self, points: int = 200) -> tuple[Array, Array]:
        """(q, v) along the boundary, ``points`` samples [rad | m], [rad/s | m/s]."""
        values, vectors = np.linalg.eigh(self.P2)
        angle = np.linspace(0.0, 2 * np.pi, points)
        circle = np.stack([np.cos(angle), np.sin(angle)])
        boundary = vectors @ (np.sqrt(self.rho / values)[:, None] * circle)
        return self.q0 + boundary[0], boundary[1]


@dataclass(frozen=True, eq=False)
class Portrait:
    """Everything a phase portrait shows (see the module docstring); units in ``q_unit``, ``v_unit``."""

    model: str
    joint: str
    q_unit: str
    v_unit: str
    reference: Array
    q: Array
    v: Array
    energy: Array
    equilibria: tuple[Equilibrium, ...]
    separatrix_energy: float | None
    trajectories: tuple[tuple[str, Array, Array], ...]
    region: Ellipse | None
    acceleration: Array | None = None
    held: str = ""

    @property
    def angular(self) -> bool:
        """True for a revolute joint (q in rad)."""
        return self.q_unit == "rad"

    def as_record(self) -> dict[str, object]:
        """A JSON-ready summary (the grid itself goes to the CSV)."""
        return {
            "model": self.model,
            "joint": self.joint,
            "units": {"q": self.q_unit, "v": self.v_unit, "energy": "J"},
            "reference_q": self.reference.tolist(),
            "q_range": [float(self.q[0]), float(self.q[-1])],
            "v_range": [float(self.v[0]), float(self.v[-1])],
            "equilibria": [{"q": e.q, "energy_J": e.energy, "stable": e.stable} for e in self.equilibria],
            "separatrix_energy_J": self.separatrix_energy,
            "held": self.held,
            "trajectories": [label for label, _, _ in self.trajectories],
            "region": None
            if self.region is None
            else {"q0": self.region.q0, "P2": self.region.P2.tolist(), "rho": self.region.rho},
        }


def compute(
    robot: Robot,
    *,
    joint: str | None = None,
    reference: ArrayLike | None = None,
    q_range: tuple[float, float] | None = None,
    v_range: tuple[float, float] | None = None,
    resolution: int = DEFAULT_RESOLUTION,
    trajectories: Sequence[tuple[str, ArrayLike, ArrayLike]] = (),
    region: tuple[ArrayLike, ArrayLike, float] | None = None,
) -> Portrait:
    """The phase portrait of ``joint`` with the others held at ``reference``.

    Args:
        robot: the model.
        joint: the moving joint (one coordinate, one velocity); default the first passive joint,
            else the first joint.
        reference: the full configuration (nq,) the other joints are held at; default the neutral pose.
        q_range: the joint's extent; default one turn about the reference for a revolute
            joint (its limits, or +-1 m, for a prismatic one).
        v_range: the speed extent; default one that holds the separatrix and the trajectories.
        resolution: grid points per axis (at least 11).
        trajectories: (label, q (n, nq), v (n, nv)) runs of the full robot to draw.
        region: (q_eq (nq,), P (2 nv, 2 nv), rho) an LQR's region e^T P e < rho, e = [q - q_eq; v].

    Raises:
        UnknownNameError: an unknown joint; InputError: a joint of more than one coordinate, a
        reference or trajectory of the wrong shape, a bad range or resolution.
    """
    name = _joint(robot, joint)
    iq = robot.joint(name).idx_q
    iv = robot.joint(name).idx_v
    ref = robot.neutral() if reference is None else np.asarray(reference, dtype=np.float64).copy()
    if ref.shape != (robot.nq,) or not np.all(np.isfinite(ref)):
        raise InputError(f"portrait reference must be {robot.nq} finite numbers (one per coordinate), got {ref!r}")
    if not isinstance(resolution, int) or not 11 <= resolution <= 2001:
        raise InputError(f"portrait resolution must be an integer from 11 to 2001, got {resolution!r}")
    prismatic = robot.joint(name).kind.startswith("JointModelP")
    runs = tuple(_trajectory(robot, label, q, v, iq, iv) for label, q, v in trajectories)

    def state(x: float) -> Array:
        q = ref.copy()
        q[iq] = x
        return q

    lo, hi = q_range if q_range is not None else _default_q_range(robot, name, ref[iq], prismatic)
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise InputError(f"portrait range of {name} must be two finite numbers, low < high, got {lo}, {hi}")
    if not prismatic:  # each run's angle wrapped into the plotted turn, broken where it wraps
        runs = tuple((label, *_wrapped(q, v, lo, hi)) for label, q, v in runs)
    elif q_range is None and runs:  # a prismatic plane reaches as far as the runs go
        lo = min(lo, *(float(np.nanmin(q)) for _, q, _ in runs))
        hi = max(hi, *(float(np.nanmax(q)) for _, q, _ in runs))
    equilibria = _equilibria(robot, state, iv, lo, hi)
    unstable = [e.energy for e in equilibria if not e.stable]
    separatrix = max(unstable) if unstable else None

    xs = np.linspace(lo, hi, resolution)
    inertia = np.array([robot.M(state(x))[iv, iv] for x in xs])
    potential = np.array([robot.potential_energy(state(x)) for x in xs])
    if v_range is None:
        v_range = _default_v_range(inertia, potential, separatrix, runs)
    vlo, vhi = v_range
    if not (np.isfinite(vlo) and np.isfinite(vhi) and vlo < vhi):
        raise InputError(f"portrait speed range must be two finite numbers, low < high, got {vlo}, {vhi}")
    vs = np.linspace(vlo, vhi, resolution)
    energy = 0.5 * inertia[None, :] * vs[:, None] ** 2 + potential[None, :]
    acceleration = -np.gradient(energy, xs, axis=1) / inertia[None, :]  # v' = -(dE/dq_j) / M_jj

    ellipse = None
    if region is not None:
        q_eq, P, rho = region
        P = np.asarray(P, dtype=np.float64)
        n = P.shape[0] // 2
        pick = [iv, n + iv]
        ellipse = Ellipse(q0=float(np.asarray(q_eq, dtype=np.float64)[iq]), P2=P[np.ix_(pick, pick)], rho=float(rho))
    return Portrait(
        model=robot.name,
        joint=name,
        q_unit="m" if prismatic else "rad",
        v_unit="m/s" if prismatic else "rad/s",
        reference=ref,
        q=xs,
        v=vs,
        energy=energy,
        equilibria=equilibria,
        separatrix_energy=separatrix,
        trajectories=runs,
        region=ellipse,
        acceleration=acceleration,
        held=_held(robot, ref, iq),
    )


def _held(robot: Robot, reference: Array, iq: int) -> str:
    """The other coordinates' values, "joint1 = 1.571 rad" (or "" for a one-joint model)."""
    parts = []
    for name in robot.joint_names:
        info = robot.joint(name)
        if info.nq != 1 or info.idx_q == iq:
            continue
        unit = "m" if info.kind.startswith("JointModelP") else "rad"
        parts.append(f"{name} = {reference[info.idx_q]:.4g} {unit}")
    return ", ".join(parts)


def _wrapped(q: Array, v: Array, lo: float, hi: float) -> tuple[Array, Array]:
    """Angles moved by whole turns into [c - pi, c + pi) about the window's centre c; a NaN pair where they wrap."""
    centre = 0.5 * (lo + hi)
    wrapped = (q - centre + np.pi) % (2 * np.pi) - np.pi + centre
    jumps = np.flatnonzero(np.abs(np.diff(wrapped)) > np.pi) + 1
    return np.insert(wrapped, jumps, np.nan), np.insert(np.asarray(v, dtype=np.float64), jumps, np.nan)


def _joint(robot: Robot, joint: str | None) -> str:
    names = list(robot.joint_names)
    if joint is None:
        joint = robot.passive_joints[0] if robot.passive_joints else names[0]
    if joint not in names:
        raise UnknownNameError(f"joint of {robot.name}", joint, names)
    info = robot.joint(joint)
    if info.nq != 1 or info.nv != 1:
        raise InputError(
            f"a portrait needs a joint of one coordinate (revolute or prismatic); {joint} has nq = {info.nq}"
        )
    return joint


def _default_q_range(robot: Robot, name: str, centre: float, prismatic: bool) -> tuple[float, float]:
    iq = robot.joint(name).idx_q
    if prismatic:
        lo, hi = float(robot.model.lowerPositionLimit[iq]), float(robot.model.upperPositionLimit[iq])
        return (lo, hi) if np.isfinite(lo) and np.isfinite(hi) and lo < hi else (centre - 1.0, centre + 1.0)
    return centre - 1.25 * np.pi, centre + 1.25 * np.pi  # a turn and a bit: the equilibria at +-pi inside


def _equilibria(robot: Robot, state: object, iv: int, lo: float, hi: float) -> tuple[Equilibrium, ...]:
    def g(x: float) -> float:
        return float(robot.G(state(x))[iv])  # type: ignore[operator]

    xs = np.linspace(lo, hi, SCAN_POINTS)
    gs = np.array([g(x) for x in xs])
    scale = max(float(np.abs(gs).max()), 1e-300)
    found: list[Equilibrium] = []
    if np.abs(gs).max() <= 1e-12 * max(1.0, scale):
        return ()  # no gravity along this joint: every point is at rest
    for a, b, ga, gb in zip(xs[:-1], xs[1:], gs[:-1], gs[1:], strict=True):
        if ga == 0.0 or ga * gb < 0.0:
            x = a if ga == 0.0 else float(brentq(g, a, b, xtol=1e-14))
            h = 1e-6 * max(1.0, abs(x))
            slope = (g(x + h) - g(x - h)) / (2 * h)
            found.append(Equilibrium(q=x, energy=robot.potential_energy(state(x)), stable=slope > 0))  # type: ignore[operator]
    return tuple(found)


def _default_v_range(
    inertia: Array, potential: Array, separatrix: float | None, runs: tuple[tuple[str, Array, Array], ...]
) -> tuple[float, float]:
    top = 0.0
    if separatrix is not None:
        top = float(np.sqrt(np.maximum(2 * (separatrix - potential) / inertia, 0.0)).max())
    elif np.ptp(potential) > 0:
        top = float(np.sqrt(2 * np.ptp(potential) / inertia.min()))
    for _, _, v in runs:
        top = max(top, float(np.nanmax(np.abs(v))))
    top = SPEED_MARGIN * top if top > 0 else 1.0
    return -top, top


def _trajectory(robot: Robot, label: str, q: ArrayLike, v: ArrayLike, iq: int, iv: int) -> tuple[str, Array, Array]:
    q_, v_ = np.asarray(q, dtype=np.float64), np.asarray(v, dtype=np.float64)
    if q_.ndim != 2 or q_.shape[1] != robot.nq or v_.shape != (q_.shape[0], robot.nv):
        raise InputError(
            f"trajectory {label!r} must have q of shape (n, {robot.nq}) and v of shape (n, {robot.nv}); "
            f"got {q_.shape} and {v_.shape}"
        )
    return label, q_[:, iq].copy(), v_[:, iv].copy()
