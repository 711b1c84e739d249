"""Energy-based swing-up from hanging: Astrom-Furuta for the cart-pole, Spong's PFL plus a pump for the Pendubot.

Both pump the pendulum's energy E (the pole's, link 2's) towards its value E_up upright at rest, and both
give their torque through the collocated partial feedback linearisation of
:mod:`robodyn.control.pfl` (a commanded acceleration of the actuated joint), clipped to the
URDF's effort limit. Neither balances: :mod:`robodyn.control.switch` hands over to the LQR.

**Cart-pole** (K. J. Astrom and K. Furuta, "Swinging up a pendulum by energy control",
Automatica 36, 2000). The pole's own energy E = 1/2 J theta'^2 + m g l (cos theta - 1),
J = m l^2 + I, is 0 upright at rest and obeys dE/dt = -m l y'' theta' cos theta. The cart's
acceleration

    y''_cmd = sat_{a_max}( k_E (E - E_up) (theta' cos theta + kick) ) - k_y y - k_v y'

makes dE/dt = -m l k_E (E - E_up) (theta' cos theta)^2 <= 0 towards E_up (the small ``kick``
starts the swing from rest, where theta' = 0, and vanishes with E - E_up). The PD terms keep the
cart near the middle; a rail guard brakes at ``a_max`` when the cart could not otherwise stop
inside the rail's usable interval. A pole whose centre of mass lies below its hinge at q = 0
(l < 0) has its upright at theta = pi (:func:`robodyn.control.plant.rests`): the energy is measured
from cos theta_up and the pump's sign follows l's. Assumes: the pole's hinge is frictionless (the energy law
ignores its damping), the cart's force is its only input, the state is measured.

**Pendubot** (M. W. Spong, "The swing up control problem for the Acrobot", IEEE Control Systems
15(1), 1995: collocated PFL of the actuated joint, a PD to its upright plus an energy-pumping term;
the pump is Astrom-Furuta's, with link 1's tip as link 2's cart). Through the PFL q1'' = w, link 1
is a critically damped second-order system about its upright, and link 2 a pendulum hanging from
link 1's tip, energy E2 = 1/2 J2 phi'^2 + m2 g lc2 (cos psi - 1) (phi = q1 + q2 its absolute angle,
psi that angle from its upright, e1 = q1 - q1_up). Near the upright a shoulder acceleration w gives
link 2's pivot the sideways acceleration -l1 w cos e1, and dE2/dt = -m2 lc2 l1 w phi' cos psi cos e1 (to first
order), so

    w = sat_{a_max}( k_E (E2 - E2_up) (phi' cos psi cos e1 + kick) ) - k_p e1 - k_d q1'

drives E2 to its upright value while the PD keeps link 1 up: link 2 then swings up into the LQR's
region. In units of link 2's pendulum (E2 / (m2 g lc2), time w2 t) the energy a swing gains goes as
the coupling kappa = m2 l1 lc2 / J2 times the shoulder's swing a = accel_max / w2^2 [rad], and the
pump takes about pi^2 / (kappa a w2) [s]: a Pendubot whose link 2 is mostly rotational inertia
(kappa 0.11 against 0.90 on Spong and Block's machine) needs eight times the swings. Where that time
exceeds ``PUMP_TIME`` the shoulder swings harder, up to about 1 rad (:func:`pump_ratio`).

Fantoni, Lozano and Spong's law (IEEE TAC 45(4), 2000), which pumps the total energy, was
robodyn's first: its closed loop has a second equilibrium, link 1 upright with link 2 hanging,
which it leaves only slowly (growth rates of 0.01 to 0.05 per second on drawn Pendubots), and 10
to 14 % of the benchmark's drawn Pendubots balanced; this one's pump leaves it at once.
Assumes: lossless joints, the torque on the shoulder is the only input, the state is measured.

Every number comes from the model: E_up from its potential at the upright, Mbar and hbar from its
M, C, G, the gains from its energy and time scales. Whether
a run balanced, and why not, is :mod:`robodyn.control.outcome`'s to say.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.control.pfl import Collocated, collocated
from robodyn.control.plant import Plant, wrap
from robodyn.errors import InputError
from robodyn.fileio import is_number
from robodyn.kinds import params

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class CartPoleEnergy:
    """Astrom-Furuta energy swing-up of a cart-pole; call as tau(t, q, v) -> (force [N],).

    ``k_energy`` [m/s^2 per J rad/s], ``accel_max`` [m/s^2], ``k_position`` [1/s^2],
    ``k_velocity`` [1/s], ``kick`` [rad/s]; ``m``, ``l``, ``J``, ``g`` the pole's parameters.
    """

    plant: Plant
    pfl: Collocated
    k_energy: float
    accel_max: float
    k_position: float
    k_velocity: float
    kick: float
    m: float
    l: float
    J: float
    g: float
    m_total: float
    energy_up: float = 0.0
    cos_up: float = 1.0
    energy_name: ClassVar[str] = "the pole's ½ J θ̇² + m g l (cos θ − cos θ_up), zero upright at rest"

    def energy(self, q: Array, v: Array) -> float:
        """The pole's energy 1/2 J theta'^2 + m g l (cos theta - cos theta_up) [J], 0 upright at rest.

        theta_up is the plant's upright: 0 for a pole above its hinge at q = 0 (l > 0), pi for one
        below it (l < 0); ``cos_up`` holds its cosine.
        """
        return 0.5 * self.J * float(v[1]) ** 2 + self.m * self.g * self.l * (float(np.cos(q[1])) - self.cos_up)

    def acceleration(self, q: Array, v: Array) -> float:
        """The commanded cart acceleration [m/s^2], rail guard applied."""
        sigma = float(v[1] * np.cos(q[1])) + self.kick
        side = -1.0 if self.l < 0 else 1.0  # dE/dt = -m l y'' theta' cos theta: a pole below its hinge pumps reversed
        pump = float(np.clip(side * self.k_energy * (self.energy(q, v) - self.energy_up) * sigma, -1.0, 1.0))
        accel = self.accel_max * pump - self.k_position * float(q[0]) - self.k_velocity * float(v[0])
        return rail_guard(self.plant, float(q[0]), float(v[0]), accel, self.accel_max)

    def __call__(self, t: float, q: Array, v: Array) -> Array:
        """The cart force [N] (1,), from the commanded acceleration by collocated PFL, clipped to the effort limit."""
        return self.plant.saturate(self.pfl.torque(q, v, np.array([self.acceleration(q, v)])))


@dataclass(frozen=True, eq=False)
class PendubotEnergy:
    """Energy swing-up of a Pendubot's passive link through collocated PFL; call as tau(t, q, v) -> (u [N m],).

    The shoulder's commanded acceleration (see the module's formula) holds link 1 near its upright
    with the PD ``k_p`` [1/s^2], ``k_d`` [1/s] and pumps link 2's energy with at most ``accel_max``
    [rad/s^2]; ``k_energy`` [1/J 1/(rad/s)] the pump's gain, ``kick`` [rad/s] its start from rest;
    ``weight`` = m2 g lc2 [N m] and ``inertia`` = J2 [kg m^2] link 2's own pendulum, read from the
    model's G and M; ``energy_up`` [J] link 2's energy target (0: upright at rest); ``swing_effort``
    [N m] the torque the swing may use; ``hold_torque`` [N m] the model's torque that holds both links
    horizontal, |G_1| there, the scale of the torque every swing needs.
    """

    plant: Plant
    pfl: Collocated
    k_energy: float
    accel_max: float
    k_p: float
    k_d: float
    kick: float
    weight: float
    inertia: float
    energy_up: float
    swing_effort: float
    hold_torque: float
    energy_name: ClassVar[str] = "link 2's ½ J2 φ̇² + m2 g lc2 (cos ψ − 1), zero upright at rest"

    def energy(self, q: Array, v: Array) -> float:
        """Link 2's pendulum energy 1/2 J2 phi'^2 + m2 g lc2 (cos psi - 1) [J], 0 upright at rest.

        phi' = q1' + q2' is link 2's absolute rate, psi its absolute angle from its upright.
        """
        up = self.plant.upright()
        psi = float(q[0] + q[1] - up[0] - up[1])
        rate = float(v[0] + v[1])
        return 0.5 * self.inertia * rate * rate + self.weight * (np.cos(psi) - 1.0)

    def acceleration(self, q: Array, v: Array) -> float:
        """The shoulder's commanded acceleration w [rad/s^2]: PD to upright plus the pump on link 2."""
        up = self.plant.upright()
        e1 = float(wrap(q[0] - up[0]))
        psi = float(q[0] + q[1] - up[0] - up[1])
        sigma = float(v[0] + v[1]) * np.cos(psi) * np.cos(e1) + self.kick
        pump = np.clip(self.k_energy * (self.energy(q, v) - self.energy_up) * sigma, -1.0, 1.0)
        return float(self.accel_max * pump - self.k_p * e1 - self.k_d * float(v[0]))

    def __call__(self, t: float, q: Array, v: Array) -> Array:
        """The shoulder torque [N m] (1,), clipped to the swing's effort and the effort limit."""
        u = self.pfl.torque(q, v, np.array([self.acceleration(q, v)]))
        return self.plant.saturate(np.clip(u, -self.swing_effort, self.swing_effort))


def rail_guard(plant: Plant, y: float, vy: float, accel: float, brake: float) -> float:
    """``accel`` [m/s^2], or full braking ``-brake sign(vy)`` when the cart could not stop inside the rail.

    The cart is at y [m] moving at vy [m/s]; braking at ``brake`` [m/s^2] it stops at y + vy |vy| / (2 brake).
    """
    if plant.rail is None:
        return accel
    lo, hi = plant.rail
    stop = y + vy * abs(vy) / (2.0 * brake)  # where the cart stops braking at ``brake`` from now on
    if vy > 0 and stop >= hi:
        return min(accel, -brake)
    if vy < 0 and stop <= lo:
        return max(accel, brake)
    return accel


def cart_pole(
    plant: Plant,
    *,
    k_energy: float | None = None,
    accel_max: float | None = None,
    k_position: float | None = None,
    k_velocity: float | None = None,
    kick: float | None = None,
    energy_offset: float = 0.0,
) -> CartPoleEnergy:
    """The cart-pole's swing-up law, its default gains scaled from the model's own numbers.

    With the pole's natural frequency w0 = sqrt(m g l / J) [rad/s] and its energy scale m g l [J],
    the law is the same on every cart-pole up to scale when k_energy ~ 1 / (m g l w0),
    k_position ~ w0^2, k_velocity ~ w0 and kick ~ w0. The defaults are the dimensionless gains
    first tuned on the built-in cart-pole (k_energy = 1, k_position = 2, k_velocity = 3, kick = 0.1
    there, w0 = 3.836 rad/s), rescaled by the model's w0 and m g l.

    ``accel_max`` defaults to g (Astrom-Furuta's n = 1), capped at 80 % of what the effort limit gives.

    ``energy_offset`` [J] shifts the target E_up = 0 (for experiments; the upright needs 0).
    """
    p = params.extract(plant.robot, "cart_pole")
    m, l, g = p["m"], p["l"], p["g"]
    J = m * l * l + p["I"]
    m_total = p["m_cart"] + m
    energy_scale, omega = _pole_scale(m, l, J, g)
    ref_energy, ref_omega = _pole_scale(*_CART_POLE_REFERENCE)
    k_energy = 1.0 * (ref_energy * ref_omega) / (energy_scale * omega) if k_energy is None else k_energy
    k_position = 2.0 * (omega / ref_omega) ** 2 if k_position is None else k_position
    k_velocity = 3.0 * (omega / ref_omega) if k_velocity is None else k_velocity
    kick = 0.1 * (omega / ref_omega) if kick is None else kick
    if accel_max is None:
        accel_max = min(g, 0.8 * float(plant.effort[0]) / m_total)
    require_positive(k_energy=k_energy, accel_max=accel_max)
    require_non_negative(k_position=k_position, k_velocity=k_velocity, kick=kick)
    return CartPoleEnergy(
        plant,
        collocated(plant.robot),
        k_energy,
        accel_max,
        k_position,
        k_velocity,
        kick,
        m,
        l,
        J,
        g,
        m_total,
        energy_offset,
        float(np.cos(plant.upright()[1])),
    )


def _pole_scale(m: float, l: float, J: float, g: float) -> tuple[float, float]:
    """(m g l [J], w0 = sqrt(m g l / J) [rad/s]): the pole's energy and time scales."""
    energy = abs(m * g * l)
    return energy, float(np.sqrt(energy / J)) if J > 0 and energy > 0 else 1.0


# (m, l, J, g) of the built-in cart-pole, where the dimensionless gains were tuned.
_CART_POLE_REFERENCE = (0.1, 0.5, 0.1 * 0.5 * 0.5 + 8.3333333e-3, 9.81)


def pendubot(
    plant: Plant,
    *,
    k_energy: float | None = None,
    accel_max: float | None = None,
    k_p: float | None = None,
    k_d: float | None = None,
    kick: float | None = None,
    energy_offset: float = 0.0,
    swing_effort: float | None = None,
) -> PendubotEnergy:
    """The Pendubot's swing-up, its default gains from the model's own numbers.

    Link 2 hangs from link 1's tip as a pendulum of weight moment m2 g lc2 = max |G_2| [N m] and
    inertia J2 = M_22 [kg m^2] about the elbow (both read from the model), natural frequency
    w2 = sqrt(m2 g lc2 / J2) [rad/s]. Every gain is that pendulum's scale times a dimensionless
    number, so the law is the same on every Pendubot up to the scale of masses, lengths and time
    (but for ``PUMP_TIME``, a time in seconds, which raises the pump of a slow one):

    * ``k_p`` = (``PD_RATIO`` w2)^2, ``k_d`` = 2 ``PD_RATIO`` w2: link 1 critically damped at
      0.6 w2, slower than link 2 swings, so the pump's shaking of the shoulder reaches link 2;
    * ``accel_max`` = ``PUMP_RATIO`` w2^2 (the shoulder swings about 0.5 rad to pump), raised up to
      ``PUMP_MAX`` w2^2 where the pump would take longer than ``PUMP_TIME`` (:func:`pump_ratio`: the
      energy a swing gains goes as the coupling m2 l1 lc2 / J2 times the shoulder's swing);
    * ``k_energy`` = ``PUMP_GAIN`` / (m2 g lc2 w2): the pump saturates until link 2 is near its target;
    * ``kick`` = ``KICK_RATIO`` w2: starts the pump when link 2 hangs at rest below an upright link 1.

    The swing uses at most ``swing_effort`` [N m], by default the effort limit.

    ``energy_offset`` [J] shifts link 2's target E_up = 0 (for experiments; the upright needs 0).
    """
    given = {
        name: value
        for name, value in (
            ("k_energy", k_energy), ("accel_max", accel_max), ("k_p", k_p), ("k_d", k_d), ("swing_effort", swing_effort)
        )
        if value is not None
    }  # fmt: skip
    require_positive(**given)  # before any arithmetic on them (the defaults come from the model)
    if kick is not None:
        require_non_negative(kick=kick)
    require_finite(energy_offset=energy_offset)
    robot = plant.robot
    up = plant.upright()
    M = dynamics.mass_matrix(robot.model, robot.data, up)
    inertia = float(M[1, 1])  # J2 = m2 lc2^2 + I2 (+ armature): the same at every q of a Pendubot
    straight = up + np.array([0.0, np.pi / 2])  # link 2 horizontal: |G_2| = m2 g lc2
    weight = abs(float(dynamics.gravity(robot.model, robot.data, straight)[1]))
    if not (inertia > 0 and weight > 0):
        raise InputError(
            f"swing_up needs link 2 to weigh and to have inertia; {robot.name} has m2 g lc2 = {weight:.4g} N m"
        )
    omega = float(np.sqrt(weight / inertia))  # [rad/s] link 2's own pendulum frequency
    k_p = (PD_RATIO * omega) ** 2 if k_p is None else k_p
    k_d = 2.0 * PD_RATIO * omega if k_d is None else k_d
    accel_max = pump_ratio(coupling(plant), omega) * omega**2 if accel_max is None else accel_max
    k_energy = PUMP_GAIN / (weight * omega) if k_energy is None else k_energy
    kick = KICK_RATIO * omega if kick is None else kick
    hold = hold_torque(plant)
    cap = float(plant.effort[0]) if swing_effort is None else min(float(swing_effort), float(plant.effort[0]))
    pfl = collocated(robot)
    return PendubotEnergy(
        plant, pfl, float(k_energy), float(accel_max), float(k_p), float(k_d), float(kick),
        weight, inertia, float(energy_offset), cap, hold,
    )  # fmt: skip


def coupling(plant: Plant) -> float:
    """The coupling kappa = m2 l1 lc2 / J2 [-], how strongly the shoulder swings link 2, from the model's M.

    M_12 = J2 + m2 l1 lc2 cos q2 (q2 the elbow's angle from straight), so m2 l1 lc2 is half the
    difference of M_12 with the arm straight and folded; J2 = M_22.
    """
    robot = plant.robot
    up = plant.upright()
    straight = dynamics.mass_matrix(robot.model, robot.data, np.array([up[0], 0.0]))
    folded = dynamics.mass_matrix(robot.model, robot.data, np.array([up[0], np.pi]))
    return abs(float(straight[0, 1] - folded[0, 1])) / 2.0 / float(straight[1, 1])


def pump_ratio(kappa: float, omega: float) -> float:
    """The pump's acceleration in units of w2^2 [-] for a Pendubot of coupling ``kappa`` and w2 = ``omega`` [rad/s].

    Each swing of link 2 gains energy in proportion to kappa times the shoulder's swing a = accel_max /
    w2^2 [rad]; the saturated pump, a square wave of a w2^2, brings link 2 from hanging to its
    upright energy in about pi^2 / (kappa a w2) [s] (:func:`pump_time`). The pump keeps ``PUMP_RATIO``
    where that is within ``PUMP_TIME`` and raises a to bring it there, up to ``PUMP_MAX``.
    """
    if not kappa > 0:
        return PUMP_MAX
    needed = PUMP_RATIO * pump_time(kappa, omega, PUMP_RATIO) / PUMP_TIME  # the a whose pump takes PUMP_TIME
    return float(np.clip(needed, PUMP_RATIO, PUMP_MAX))


def pump_time(kappa: float, omega: float, ratio: float) -> float:
    """About how long [s] the saturated pump takes to bring link 2 from hanging to its upright energy.

    The energy balance dE2/dt = -m2 l1 lc2 w phi' cos psi cos e1, with the shoulder's acceleration w a
    square wave of ``ratio`` w2^2 in phase with phi' (about half of which passes link 1's PD), adds
    about 2 kappa ``ratio`` rad of swing per period of link 2: pi^2 / (kappa ``ratio`` w2) [s] from
    hanging to upright, kappa the coupling, w2 = ``omega`` [rad/s]. Measured times: see ``PUMP_TIME``.
    """
    return float(np.pi**2 / (kappa * ratio * omega))


def hold_torque(plant: Plant) -> float:
    """|G_1| [N m] with both links horizontal (q = upright - (pi/2, 0)): the torque that holds the arm out straight."""
    robot = plant.robot
    horizontal = plant.upright() - np.array([np.pi / 2, 0.0])
    return abs(float(dynamics.gravity(robot.model, robot.data, horizontal)[0]))


def lift_torque(plant: Plant) -> float:
    """|G_1| [N m] with link 1 horizontal and link 2 hanging from its tip, (m1 lc1 + m2 l1) g.

    The torque that raises link 1 past horizontal: below it link 1 leans where gravity matches the torque.
    """
    robot = plant.robot
    horizontal = plant.upright()[0] - np.pi / 2
    hanging = plant.hanging()
    q = np.array([horizontal, hanging[0] + hanging[1] - horizontal])  # link 2's absolute angle as it hangs
    return abs(float(dynamics.gravity(robot.model, robot.data, q)[0]))


def swing_reaction(law: PendubotEnergy | CartPoleEnergy) -> float:
    """The largest |u| [N m | N] holding link 1 (the cart) still while link 2 (the pole) swings at its upright energy.

    Link 1 upright (the cart centred), link 2 through a whole turn on its orbit E = 0: the PFL's hbar
    there, from the model's M, C, G. The swing ends on that orbit, so an effort below it cannot give the
    actuated joint the acceleration the law commands there, whatever the gains.
    """
    if isinstance(law, PendubotEnergy):
        weight, inertia = law.weight, law.inertia
    else:
        weight, inertia = abs(law.m * law.g * law.l), law.J
    up = law.plant.upright()
    worst = 0.0
    for psi in np.linspace(-np.pi, np.pi, REACTION_SAMPLES):
        rate = float(np.sqrt(max(2.0 * weight * (1.0 - np.cos(psi)) / inertia, 0.0)))  # E = 0: upright energy
        q, v = up + np.array([0.0, psi]), np.array([0.0, rate])
        worst = max(worst, abs(float(law.pfl.reduced(q, v)[1][0])))
    return worst


def swing_need(law: PendubotEnergy | CartPoleEnergy) -> tuple[float, str]:
    """(the effort [N m | N] the swing-up needs, how it was found): the level below which it is not expected to work.

    The largest of the model's own figures: for a Pendubot the lift torque (:func:`lift_torque`, below
    it link 1 stays below horizontal), for a cart-pole ``NEED_CART_POLE`` (m_cart + m) g (the force that
    gives the cart that fraction of g), and for both the swing's reaction (:func:`swing_reaction`).
    See the constants for how each was measured.
    """
    reaction = swing_reaction(law)
    if isinstance(law, PendubotEnergy):
        lift = lift_torque(law.plant)
        swing = f"link 2 swinging with its upright energy pulls on the shoulder with up to {reaction:.4g} N m"
        if lift >= reaction:
            return lift, f"the {lift:.4g} N m that holds link 1 horizontal with link 2 hanging from its tip"
        return reaction, swing
    weight = law.m_total * law.g
    if NEED_CART_POLE * weight >= reaction:
        return (
            NEED_CART_POLE * weight,
            f"an acceleration of {NEED_CART_POLE:g} g for the {law.m_total:.4g} kg cart and pole",
        )
    return reaction, f"the pole swinging with its upright energy pulls on the cart with up to {reaction:.4g} N"


# What a swing-up needs, from the model. Pendubot: the lift torque. Measured from hanging, 30 s runs,
# on the built-in Pendubot and three drawn ones (benchmarks/bench_swing_up.py's seed 0, systems 62, 71,
# 74, whose effort lay between 0.75 x the hold torque, the need first used, and the lift torque):
# at 0.96 x the lift torque none balanced, link 1 leaning below horizontal with the torque saturated;
# at 0.97 x two of the four, at 0.99 x and above all four (the built-in's 2 N m is 0.977 x its
# 2.046 N m and balances: link 2's swing lends the last 2 to 3 %). Those runs had the kick at 0.05 w2;
# with 0.01 w2 link 2 lends more and the lift torque is conservative by up to about 10 %: system 62
# balances at 0.92 x, not at 0.88 x (link 1 swings above horizontal, and leans below it at 0.80 x),
# and system 44 of the same family at 0.90 x in the benchmark. The swing's reaction, measured
# the same way on the built-in cart-pole, cart-poles 62 and 82 of seed 20 and the Spong-Block
# Pendubot 58 of seed 1 (efforts 0.27 to 0.59 x their reaction in the benchmark, where none balanced,
# the torque saturated): at 0.8 x the reaction none of the four balanced, at 0.9 x and above all four.
REACTION_SAMPLES = 181  # points of the orbit, 2 degrees apart
# Cart-pole: Astrom-Furuta's swing takes more swings the smaller the acceleration; measured from
# hanging on the built-in cart-pole, 30 s runs: 0.02 to 0.15 x (m_cart + m) g never balance, 0.2 x
# balances at 19.7 s, 0.3 x at 12.9 s, 0.5 x at 6.7 s. So "needs" means: to balance within 30 s.
NEED_CART_POLE = 0.2

# The Pendubot law's dimensionless gains, in units of link 2's pendulum (w2, m2 g lc2): measured
# on 20 drawn Pendubots from hanging (benchmarks/bench_swing_up.py's families, 30 s), PD at 0.3 and
# 0.6 w2, pump 0.2 and 0.5 w2^2, gain 1 and 10: 0.6 / 0.5 / 10 balanced all 15 whose effort allowed,
# median 4.5 s (0.3 / 0.5 / 10 too, 5.5 s; a gain of 1 or a pump of 0.2 lost 1 to 7 of the 15).
PD_RATIO = 0.6
PUMP_RATIO = 0.5
PUMP_GAIN = 10.0
# A weakly coupled Pendubot (kappa = m2 l1 lc2 / J2 small: link 2 mostly rotational inertia) gains
# little energy a swing. The pump's time pi^2 / (kappa a w2) (pump_time) against the time to balance
# measured from hanging with a = PUMP_RATIO (benchmarks/bench_swing_up.py, seed 0 and 1, the 16
# slowest drawn Pendubots that balanced): 21.0 s predicted / 22.1 s measured, 20.2 / 23.2, 18.0 / 19.9,
# 17.1 / 17.7, 24.5 / 27.9, 18.5 / 18.4, ...: the pump is the time. Where it exceeds PUMP_TIME the
# shoulder swings harder, up to PUMP_MAX w2^2 (link 1 then swings about 1 rad from its upright, short
# of horizontal). Spong-Block system 88 (kappa 0.11, w2 4.65 rad/s, predicted 38 s) balanced at 43 s
# with 0.5 w2^2, 26 s with 0.75, 16 s with 1.0, 14 s with 1.5 (the torque at its limit). Raising it
# on every Pendubot below the built-in's coupling instead (a = 0.5 x 0.89 / kappa) lost four
# systems of kappa 0.29 to 0.80 whose pump took under 12 s: their link 1 swung too far to catch.
PUMP_TIME = 20.0  # [s] the longest pump the law accepts before swinging the shoulder harder
PUMP_MAX = 1.0
# The kick, as Astrom-Furuta's: a small bias that starts the pump where link 2 is at rest (phi' = 0).
# At hanging (E2 - E2_up = -2 m2 g lc2) it commands 2 PUMP_GAIN KICK_RATIO of the pump's acceleration,
# which the PD answers by leaning link 1 PUMP_RATIO / PD_RATIO^2 times that [rad] off its upright:
# 0.2 of the pump, 0.28 rad. (0.05, the first value, saturated the pump there and held link 1 at
# 1.4 rad, near horizontal, until link 2 moved: 8 s of the 43 s on system 88.)
KICK_RATIO = 0.01


def require_positive(**gains: float) -> None:
    """Raise InputError, naming the gain, unless every one of ``gains`` is a positive number."""
    for name, value in gains.items():
        if not (is_number(value) and value > 0):
            raise InputError(f"swing_up gain {name} must be a positive number, got {value!r}")


def require_non_negative(**gains: float) -> None:
    """Raise InputError, naming the gain, unless every one of ``gains`` is a number >= 0."""
    for name, value in gains.items():
        if not (is_number(value) and value >= 0):
            raise InputError(f"swing_up gain {name} must be a number >= 0, got {value!r}")


def require_finite(**gains: float) -> None:
    """Raise InputError, naming the gain, unless every one of ``gains`` is a finite number."""
    for name, value in gains.items():
        if not is_number(value):
            raise InputError(f"swing_up gain {name} must be a finite number, got {value!r:.40}")
