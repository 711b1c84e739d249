"""A derivation checked against Pinocchio at seeded random states, before anyone reads it.

The printed expressions themselves are checked: the text ``robodyn derive`` prints, the formula
file it writes, or (from Python) the expressions compiled with sympy's ``lambdify``, evaluated at
``samples`` random states beside the robot's own M, C and G (Pinocchio's CRBA,
Coriolis matrix and RNEA gravity), mapped to the formula's coordinates exactly as
``robodyn check`` maps them (``M_f = S^T M S``, ``S = dq_urdf / dq_formula = A^-1`` for
q = A q_urdf + b). Every entry of M, C, C v and G must agree to :data:`RTOL` of its quantity's largest magnitude.

The robot is read through its methods (``M``, ``C``, ``G``, ``joint``, ``neutral``): this module
imports neither Pinocchio nor the Robot.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.lagrange.symbolic import Symbolic, sympy

Array = NDArray[np.float64]

RTOL = 1e-10
"""Symbolic expressions in float64 against Pinocchio's recursions: both are exact up to round-off (~1e-15)."""

DEFAULT_SAMPLES = 20
SPEED = 2.0  # velocities drawn in [-SPEED, SPEED] [rad/s | m/s]
SLIDE = 0.5  # prismatic positions drawn in [-SLIDE, SLIDE] [m]


@dataclass(frozen=True)
class Disagreement:
    """The worst entry of one quantity: where, the two values and the relative difference."""

    quantity: str  # "M", "C", "C v" or "G"
    entry: str  # e.g. "M[0,1]"
    derived: float
    pinocchio: float
    relative: float
    q: Array
    v: Array


@dataclass(frozen=True)
class SelfCheck:
    """The self-check's verdict: the worst relative difference of each quantity, at ``samples`` states."""

    samples: int
    seed: int
    rtol: float
    worst: tuple[Disagreement, ...]

    @property
    def passed(self) -> bool:
        """Whether every quantity agrees to ``rtol``."""
        return all(d.relative <= self.rtol for d in self.worst)

    @property
    def max_relative(self) -> float:
        """The largest relative difference over M, C, C v and G."""
        return max(d.relative for d in self.worst)

    def failures(self) -> tuple[Disagreement, ...]:
        """The quantities that differ by more than ``rtol``."""
        return tuple(d for d in self.worst if d.relative > self.rtol)


def compiled(s: Symbolic) -> tuple[Any, Any, Any]:
    """(M(q, p), C(q, v, p), G(q, p)) as NumPy functions of the printed expressions."""
    sp = sympy()
    from sympy.printing.numpy import NumPyPrinter

    args_q, args_qv = (s.q, s.params), (s.q, s.v, s.params)
    options: dict[str, Any] = {"modules": "numpy", "docstring_limit": 0, "printer": NumPyPrinter(s.printer_settings())}
    return (
        sp.lambdify(args_q, s.M, **options),
        sp.lambdify(args_qv, s.C, **options),
        sp.lambdify(args_q, s.G, **options),
    )


def from_text(s: Symbolic) -> tuple[Any, Any, Any]:
    """(M(q, p), C(q, v, p), G(q, p)) compiled from the very text ``robodyn derive`` prints (:meth:`Symbolic.sstr`).

    sympy's text of these expressions is Python (``**``, ``cos``, fractions as ``1/2``), so the
    printed entries are checked themselves, and printed once: a spatial 6-joint arm's are ~10^6
    characters, and printing them is most of a derivation's time.
    """
    d = s.derivation
    n = d.n
    head = [f"    {', '.join(str(x) for x in s.q)}, = q"]
    if d.params:
        head.append(f"    {', '.join(str(x) for x in s.params)}, = p")
    rows_M = ", ".join("[" + ", ".join(s.sstr(s.M[i, j]) for j in range(n)) + "]" for i in range(n))
    rows_C = ", ".join("[" + ", ".join(s.sstr(s.C[i, j]) for j in range(n)) + "]" for i in range(n))
    entries_G = ", ".join(s.sstr(s.G[i, 0]) for i in range(n))
    source = "\n".join(
        [
            "def M(q, p):",
            *head,
            f"    return [{rows_M}]",
            "def C(q, v, p):",
            *head,
            f"    {', '.join(str(x) for x in s.v)}, = v",
            f"    return [{rows_C}]",
            "def G(q, p):",
            *head,
            f"    return [{entries_G}]",
        ]
    )
    namespace: dict[str, Any] = {"cos": np.cos, "sin": np.sin}
    exec(compile(source, "<robodyn derive's printed expressions>", "exec"), namespace)  # robodyn's own text
    return namespace["M"], namespace["C"], namespace["G"]


def self_check(
    s: Symbolic,
    robot: Any,
    *,
    samples: int = DEFAULT_SAMPLES,
    seed: int = 0,
    rtol: float = RTOL,
    formula: Mapping[str, Any] | None = None,
    text: bool = False,
) -> SelfCheck:
    """Compare the derivation's M, C, C v and G with ``robot``'s (Pinocchio) at seeded random states.

    ``robot`` is the model the derivation describes (its moving joints are the coordinates'
    joints, the others locked); its joints are found by name. The expressions are compiled with
    ``lambdify``; or, given ``formula`` (the namespace of the ``--format python`` file about to be
    written, and ``"table"``, the per-link table), that file's own ``mass_matrix``,
    ``coriolis_matrix`` and ``gravity`` are evaluated, with the parameters its
    ``parameters(robot)`` reads: the check then holds for the very file written. With ``text``
    the printed text itself is compiled (:func:`from_text`).
    """
    d = s.derivation
    if formula is None:
        fM, fC, fG = from_text(s) if text else compiled(s)
        p: Any = tuple(x.value for x in d.params)
    else:
        fM, fC, fG = formula["mass_matrix"], formula["coriolis_matrix"], formula["gravity"]
        p = formula["parameters"](formula["table"])
    rng = np.random.default_rng(seed)
    n = d.n
    cmap = d.coordinates
    back = cmap.A_inv  # d q_urdf / d q
    S = np.zeros((robot.nv, n))
    infos = [robot.joint(joint) for joint in cmap.joints]
    for j, info in enumerate(infos):
        S[info.idx_v, :] = back[j]
    rows: dict[str, list[tuple[Array, Array, Array, Array]]] = {"M": [], "C": [], "C v": [], "G": []}
    for _ in range(samples):
        q = np.array([rng.uniform(-np.pi, np.pi) if a else rng.uniform(-SLIDE, SLIDE) for a in d.angular])
        v = rng.uniform(-SPEED, SPEED, n)
        q_full = robot.neutral()
        for info, angle in zip(infos, back @ (q - cmap.b), strict=True):
            q_full[info.idx_q : info.idx_q + info.nq] = [np.cos(angle), np.sin(angle)] if info.nq == 2 else [angle]
        v_full = S @ v
        M_ref = S.T @ robot.M(q_full) @ S
        C_ref = S.T @ robot.C(q_full, v_full) @ S
        G_ref = S.T @ robot.G(q_full)
        M = np.asarray(fM(q, p), dtype=np.float64).reshape(n, n)
        C = np.asarray(fC(q, v, p), dtype=np.float64).reshape(n, n)
        G = np.asarray(fG(q, p), dtype=np.float64).reshape(n)
        rows["M"].append((M, M_ref, q, v))
        rows["C"].append((C, C_ref, q, v))
        rows["C v"].append((C @ v, C_ref @ v, q, v))
        rows["G"].append((G, G_ref, q, v))
    floor = max(float(np.max(np.abs(r[1]))) for r in rows["M"])  # a scale when a quantity is zero throughout
    worst = tuple(_worst(name, values, floor) for name, values in rows.items())
    return SelfCheck(samples, seed, rtol, worst)


def _worst(quantity: str, values: list[tuple[Array, Array, Array, Array]], floor: float) -> Disagreement:
    scale = max(max(float(np.max(np.abs(ref))) for _, ref, _, _ in values), floor, 1e-300)
    best: Disagreement | None = None
    for got, ref, q, v in values:
        diff = np.abs(got - ref)
        k = int(np.argmax(diff))
        rel = float(diff.flat[k]) / scale
        if best is None or rel > best.relative:
            index = np.unravel_index(k, got.shape)
            entry = f"{quantity.replace(' ', '')}[{','.join(str(int(x)) for x in index)}]"
            if quantity == "C v":
                entry = f"(C v)[{int(index[0])}]"
            best = Disagreement(quantity, entry, float(got.flat[k]), float(ref.flat[k]), rel, q, v)
    assert best is not None  # samples >= 1
    return best
