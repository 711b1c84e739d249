"""Stiff joint losses: is a fixed-step explicit method stable on a run's damping and friction?

A joint's losses are tau = -D v - F tanh(v / V_FRICTION) (:mod:`robodyn.sim.system`): viscous
damping D [N m s/rad] and Coulomb friction F [N m], regularised. Near v = 0 both are viscous,
of coefficient D + F / V_FRICTION, so on joint j with effective inertia m_jj = M(q0)_jj
(armature included) the velocity relaxes at the rate

    lambda_j = (D_j + F_j / V_FRICTION) / m_jj   [1/s]

(its time constant is 1 / lambda_j), a real, negative eigenvalue -lambda_j of the linearised
dynamics (the diagonal estimate: the joint's coupling to the others through M is left out). A
fixed-step explicit method is stable on it only while lambda_j dt <= x*, its stability region's
extent along the negative real axis, so the largest stable step is dt_max = x* / lambda_j.
Each joint's finding names the term that dominates its rate (``damping`` or ``Coulomb friction``).

x* is derived, not tabulated: for an explicit Runge--Kutta method the stability function is
the polynomial R(z) = 1 + sum_k z^k b^T A^(k-1) 1 of its tableau, and x* is the smallest x > 0
where |R(-x)| crosses 1 (polished by Newton to the last ulps): 2 for explicit Euler
(R = 1 + z), 2 for Heun, 2.785293563... for RK4 (where R(-x) = +1 again, the real root of
x^3 - 4 x^2 + 12 x - 24). Semi-implicit (kick-drift) Euler kicks the velocity by explicit Euler,
v += h a(q, v), and the losses act on v alone, so its x* is explicit Euler's 2. Any other explicit
fixed-step method has x* measured on its own steps by
:func:`robodyn.integrators.stability.region_radius`.

Adaptive methods shrink their step to the stiffness and implicit ones are stable on a real
negative eigenvalue (or fail loudly when their iteration cannot converge), so they get no
finding. Nothing here changes a run: the finding goes into the metadata (``stiff_friction``,
the name it had when it covered friction alone), ``robodyn simulate`` prints one warning line
from it, and a run that diverges gives it as the likely cause (:func:`robodyn.sim.run.diagnose`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.integrators import ExplicitEuler, ExplicitRungeKutta, Integrator, SemiImplicitEuler
from robodyn.integrators.stability import region_radius
from robodyn.sim.system import V_FRICTION, RobotSystem, velocity_names

Array = NDArray[np.float64]

# A root of R(-x) -+ 1 counts as real when its imaginary part is below this fraction of its size.
REAL_ROOT_RTOL = 1e-8
# The region is left at a crossing x* when |R(-x)| > 1 at x* (1 + this): a touch that stays inside is skipped.
CROSSING_PROBE = 1e-6
# Newton steps that polish a crossing of the stability polynomial to the last ulps.
NEWTON_POLISH = 8
# The warning names at most this many joints, then "and N more".
NAMED_JOINTS = 3


FRICTION, DAMPING = "Coulomb friction", "damping"


@dataclass(frozen=True)
class StiffFriction:
    """Joints whose losses (damping, regularised Coulomb friction) are too stiff for ``integrator`` at ``dt``.

    ``joints`` (names), ``rates`` lambda_j = (D_j + F_j / v_friction) / m_jj [1/s], ``dt_stable``
    x* / lambda_j [s] and ``terms`` (the term that dominates lambda_j: ``"damping"`` or
    ``"Coulomb friction"``) are per joint, stiffest first; ``limit`` is x*, the method's real-axis
    stability limit in units of h |lambda|. ``dt_max`` is the largest step stable on them all.
    """

    integrator: str
    dt: float
    limit: float
    v_friction: float
    joints: tuple[str, ...]
    rates: tuple[float, ...]
    dt_stable: tuple[float, ...]
    terms: tuple[str, ...]

    @property
    def rate(self) -> float:
        """The largest rate lambda_j [1/s]."""
        return self.rates[0]

    @property
    def dt_max(self) -> float:
        """The largest step [s] stable on every listed joint: x* / max lambda_j."""
        return self.dt_stable[0]

    def describe(self) -> dict[str, Any]:
        """The finding for a trajectory's metadata (plain floats, lists and strings)."""
        return {
            "integrator": self.integrator,
            "dt": self.dt,
            "real_axis_limit": self.limit,
            "v_friction": self.v_friction,
            "joints": list(self.joints),
            "rates": list(self.rates),
            "dt_stable": list(self.dt_stable),
            "terms": list(self.terms),
            "rate": self.rate,
            "dt_max": self.dt_max,
        }


def _terms(meta: dict[str, Any]) -> str:
    """What is stiff: "Coulomb friction", "damping" or "damping and Coulomb friction" (older metadata: friction)."""
    terms = set(meta.get("terms", [FRICTION]))
    return " and ".join(t for t in (DAMPING, FRICTION) if t in terms)


def _named(meta: dict[str, Any]) -> str:
    """The stiff joints, at most NAMED_JOINTS of them by name, then "and N more"."""
    names = list(meta["joints"])
    named = ", ".join(names[:NAMED_JOINTS])
    if len(names) > NAMED_JOINTS:
        named += f" and {len(names) - NAMED_JOINTS} more"
    return named


def warning_line(meta: dict[str, Any]) -> str:
    """The one-line warning from a trajectory's ``stiff_friction`` metadata (at most NAMED_JOINTS names)."""
    return (
        f"warning: {_terms(meta)} on {_named(meta)} is too stiff for {meta['integrator']} at "
        f"dt = {_sci(meta['dt'], 3)} s (rate {_sci(meta['rate'], 2)} 1/s; stable below dt = "
        f"{_sci(meta['dt_max'], 2)} s): expect jitter and a ledger error; use a smaller --dt, an implicit method, "
        "or --no-damping"
    )


def divergence_cause(meta: dict[str, Any]) -> tuple[str, str]:
    """(cause, suggestion) of a run that diverged with this ``stiff_friction`` finding.

    The suggested step is dt_max rounded down to one significant digit, so that it is stable on
    every stiff joint (the finding's own estimate); the other cure is a run without the losses.
    """
    cause = (
        f"{_terms(meta)} on {_named(meta)} is too stiff for {meta['integrator']} at dt = {_sci(meta['dt'], 3)} s "
        f"(time constant {_sci(1.0 / meta['rate'], 2)} s; stable below dt = {_sci(meta['dt_max'], 2)} s)"
    )
    return cause, f"run without joint losses (--no-damping), or with dt <= {_sci(below(meta['dt_max']), 1)} s"


def below(x: float) -> float:
    """Round x > 0 down to one significant digit, strictly below x: 1.1e-8 -> 1e-8, 7e-7 -> 6e-7."""
    scale = 10.0 ** np.floor(np.log10(x))
    digit = np.floor(x / scale)
    if digit * scale >= x:  # x is a round number: one step down
        digit -= 1.0
    if digit < 1.0:
        return float(9.0 * scale / 10.0)
    return float(digit * scale)


def _sci(x: float, digits: int) -> str:
    """The number x in short scientific notation to ``digits`` significant digits: 8.3e5, 1e-3, 3.4e-6."""
    mantissa, exponent = f"{x:.{digits - 1}e}".split("e")
    if "." in mantissa:
        mantissa = mantissa.rstrip("0").rstrip(".")
    return f"{mantissa}e{int(exponent)}"


def stability_polynomial(method: Integrator) -> Array | None:
    """Coefficients c_0..c_s of R(z) = sum c_k z^k for the velocity update of ``method``; None if not known.

    Explicit Euler and semi-implicit Euler's kick: R = 1 + z. An explicit Runge--Kutta tableau
    (A, b): c_0 = 1, c_k = b^T A^(k-1) 1 (A is nilpotent, so the series ends at k = s).
    """
    if isinstance(method, (ExplicitEuler, SemiImplicitEuler)):
        return np.array([1.0, 1.0])
    if isinstance(method, ExplicitRungeKutta):
        A = np.array(method.tableau.a, dtype=np.float64)
        b = np.array(method.tableau.b, dtype=np.float64)
        coefficients = [1.0]
        power = np.ones(len(b))
        for _ in range(len(b)):
            coefficients.append(float(b @ power))
            power = A @ power
        return np.array(coefficients)
    return None


def polynomial_limit(coefficients: Array) -> float:
    """x* > 0: the smallest x at which |R(-x)| leaves [-1, 1] (inf if it never does)."""
    p = np.polynomial.Polynomial(coefficients * (-1.0) ** np.arange(coefficients.size))  # P(x) = R(-x)
    dp = p.deriv()
    candidates: list[float] = []
    for target in (1.0, -1.0):
        for root in map(complex, np.asarray((p - target).roots(), dtype=np.complex128)):
            if root.real <= 0.0 or abs(root.imag) > REAL_ROOT_RTOL * abs(root):
                continue
            x = float(root.real)
            for _ in range(NEWTON_POLISH):
                slope = float(dp(x))
                if slope == 0.0:
                    break
                x -= (float(p(x)) - target) / slope
            candidates.append(x)
    for x in sorted(candidates):
        if abs(float(p(x * (1.0 + CROSSING_PROBE)))) > 1.0:
            return x
    return float("inf")


def real_axis_limit(method: Integrator) -> float | None:
    """x*, the stable extent of ``method`` along the negative real axis in h |lambda|; None for no limit.

    None for adaptive and implicit methods (they get no stiffness finding).
    """
    if method.adaptive or method.implicit or not method.fixed_step:
        return None
    coefficients = stability_polynomial(method)
    if coefficients is not None:
        return polynomial_limit(coefficients)
    return region_radius(method, float(np.pi))  # type: ignore[arg-type]


def friction_stiffness(system: RobotSystem, method: Integrator, q0: Array, dt: float) -> StiffFriction | None:
    """The stiff-losses finding for a run of ``system`` by ``method`` at step ``dt`` [s] from q0; None if none.

    Uses the system's own mass matrix (backend CRBA or the closed form, armature included) once, at q0.
    """
    viscous = system.damping + system.friction / V_FRICTION  # [N m s/rad]: the losses' slope at v = 0
    if not np.any(viscous > 0.0):
        return None
    limit = real_axis_limit(method)
    if limit is None or not np.isfinite(limit):
        return None
    m = np.diag(system.mass_matrix_free(q0))
    lossy = np.flatnonzero((viscous > 0.0) & (m > 0.0))  # m_jj = 0: a singular M, refused or diagnosed elsewhere
    rates = viscous[lossy] / m[lossy]
    stiff = rates * dt > limit
    if not np.any(stiff):
        return None
    names = velocity_names(system.robot)
    order = np.argsort(-rates[stiff], kind="stable")
    joints = lossy[stiff][order]
    r = rates[stiff][order]
    return StiffFriction(
        integrator=method.name,
        dt=float(dt),
        limit=float(limit),
        v_friction=V_FRICTION,
        joints=tuple(names[i] for i in joints),
        rates=tuple(float(x) for x in r),
        dt_stable=tuple(float(limit * m[i] / viscous[i]) for i in joints),
        terms=tuple(DAMPING if system.damping[i] > system.friction[i] / V_FRICTION else FRICTION for i in joints),
    )
