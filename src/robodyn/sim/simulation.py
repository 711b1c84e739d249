"""Simulate a robot: integrate its dynamics, keep the energy books, stop where it blows up.

:func:`simulate` assembles a :class:`robodyn.sim.system.RobotSystem` (robot + backend + losses
+ torque + the constraints: joint stops, effort limits, loops, couplings, springs), steps it
with an integrator from :mod:`robodyn.integrators`, records every step, and returns a
:class:`robodyn.Trajectory` whose ledger residual
E(t) - E(0) - W_input(t) - W_damping(t) - W_limits(t) measures the integrator's error.

Divergence is watched block by block (every ``CHECK_EVERY`` steps, then located to the
exact step): a non-finite state, a step the method cannot take, or an energy error above
``max_energy_growth`` times the energy scale stops the run; :class:`DivergenceError`
then carries the trajectory up to that step. A KeyboardInterrupt (Ctrl-C) during the run
stops it too: :class:`SimulationInterrupted` (a KeyboardInterrupt) carries the trajectory
up to the last step taken, with status ``"interrupted"``.

Before the run, q0 is checked (a ``continuous`` joint's cos/sin pair and a quaternion must
have norm 1 within ``UNIT_NORM_TOL``) and so is M(q0): a singular mass matrix is refused
rather than integrated into a blow-up that would look like the integrator's fault. A q0
outside a joint's stops is moved onto the stop, and a q0 (v0) that violates a loop is
projected onto it; both are recorded in the metadata (``q0_clamped``, ``loop_projection``).
A fixed-step explicit method too coarse for the regularised Coulomb friction of a light joint
(:mod:`robodyn.sim.stiffness`) still runs, with the finding in the metadata (``stiff_friction``).
"""

from __future__ import annotations

import reprlib
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics, integrators
from robodyn.errors import DivergenceError, InputError, ModelError, SimulationInterrupted
from robodyn.fileio import is_number
from robodyn.integrators import Integrator
from robodyn.robot import as_vector
from robodyn.sim import compile_choice, energy, whole_run
from robodyn.sim.chatter import chattering
from robodyn.sim.constraints import Constraints, Coupling, Loop, Spring
from robodyn.sim.loops import close_initial_state
from robodyn.sim.run import Progress, Run
from robodyn.sim.stiffness import friction_stiffness
from robodyn.sim.system import SINGULAR_MASS_RTOL, RobotSystem, TorqueFn, coordinate_units, robot_system
from robodyn.sim.trajectory import Trajectory

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]


# Longest run robodyn will preallocate, in steps (memory: (nq + 2 nv + 4) floats a step).
MAX_STEPS = 50_000_000

DEFAULT_MAX_ENERGY_GROWTH = 1.0

# A cos/sin pair or a quaternion in q0 must have norm 1 to this absolute tolerance: what a
# configuration written with ~16 digits (or integrated by pin.integrate) satisfies, while a
# hand-typed pair off by a visible digit does not.
UNIT_NORM_TOL = 1e-9

# Joints whose configuration holds a unit vector: kind prefix -> (first, last) index of
# that vector within the joint's q, and what it is.
_UNIT_BLOCKS = (
    ("JointModelFreeFlyer", 3, 7, "quaternion (x, y, z, w)"),
    ("JointModelSpherical", 0, 4, "quaternion (x, y, z, w)"),
    ("JointModelPlanar", 2, 4, "(cos, sin) pair"),
    ("JointModelRUB", 0, 2, "(cos, sin) pair"),
    ("JointModelRevoluteUnbounded", 0, 2, "(cos, sin) pair"),
)


def simulate(
    robot: Robot,
    q0: ArrayLike,
    v0: ArrayLike,
    *,
    duration: float,
    dt: float,
    integrator: str | Integrator = "rk4",
    torque: ArrayLike | TorqueFn | None = None,
    backend: str | None = None,
    losses: bool = True,
    limits: bool = True,
    restitution: float = 0.0,
    effort_limits: bool = True,
    loops: Sequence[Loop | Mapping[str, Any]] = (),
    couplings: Sequence[Coupling | Mapping[str, Any]] = (),
    springs: Mapping[str, Spring | Mapping[str, Any] | tuple[float, float] | float] | None = None,
    constraints: Constraints | None = None,
    rtol: float = 1e-9,
    atol: float = 1e-12,
    max_energy_growth: float | None = DEFAULT_MAX_ENERGY_GROWTH,
    progress: Progress | None = None,
) -> Trajectory:
    """Integrate ``robot`` from (q0, v0) for ``duration`` seconds and return the trajectory.

    Args:
        robot: the robot (see :func:`robodyn.load`).
        q0: initial configuration, nq entries [rad | m]; for models with ``continuous``
            joints (nq > nv) nv joint angles are accepted too. Cos/sin pairs and
            quaternions must have norm 1 within ``UNIT_NORM_TOL``.
        v0: initial velocity (nv,) [rad/s | m/s].
        duration: simulated time [s], > 0.
        dt: time step [s], > 0 and <= duration; the output interval of adaptive methods,
            whose own steps are error-controlled (and never straddle an output time).
        integrator: a name from :func:`robodyn.integrators.names` or an integrator object.
        torque: None, a constant vector (nv entries, or one per actuated joint) [N m | N],
            or a callable tau(t, q, v) -- the controller hook. Passive joints get none.
        backend: forward dynamics: ``"aba"``, ``"crba"``, ``"formula"`` or ``"numba"``. None
            (the default) runs the whole run in the compiled loop of :mod:`robodyn.sim.whole_run`
            (backend ``"numba"``: ABA compiled, checked against Pinocchio) wherever it applies,
            and otherwise ``"aba"`` (``"crba"`` on a model with mimic joints, which ABA refuses)
            in the Python pipeline; while the compiled loop's kernels are not built on this
            machine, a run that costs less than their compile takes the Python pipeline instead
            (:mod:`robodyn.sim.compile_choice`). ``"numba"`` asks for the compiled loop, and for the compiled
            ABA as the smooth stage of the Python pipeline where the loop does not apply. The
            metadata say which ran: ``backend``, ``loop`` ("compiled" | "python"),
            ``compiled_loop`` (why not, when it did not), ``event_steps`` (steps with a stop
            event, taken by the Python event stepper inside a compiled run) and ``aba_passes``
            (when it ran: "world axes", or "joint axes" on a model where those fail the check).
        losses: apply the URDF joint damping and friction (their work is booked).
        limits: enforce the URDF joint limits as stops (False: joints pass through them).
        restitution: e in [0, 1] at every stop: 0 (the default) perfectly inelastic, 1 elastic.
            The energy a stop takes is booked as ``work_limits``.
        effort_limits: clamp the commanded torque at each joint's URDF ``effort`` (an effort
            of 0 declares none); the clamped samples are counted in the metadata.
        loops: loop closures, each a :class:`~robodyn.sim.constraints.Loop` or a dict
            ``{"frame_a": ..., "frame_b": ..., "kind": "point" | "6d"}`` (frames: link names,
            or the frames Pinocchio makes).
        couplings: ``{"joint": follower, "leader": ..., "ratio": r, "offset": o}`` entries,
            q_follower = r q_leader + o, simulated as mimic joints (CRBA); q0, v0 and a
            constant torque may then be given in the coupled or in the full coordinates.
        springs: joint name -> ``{"stiffness": k, "rest": r}`` (or (k, r), or k): the
            torque -k (q - r), whose energy k (q - r)^2 / 2 is potential energy.
        constraints: all of the above as one :class:`~robodyn.sim.constraints.Constraints`
            (from a scene or a JSON file); then those keyword arguments must keep their defaults.
        rtol: relative tolerance of the adaptive methods.
        atol: absolute tolerance of the adaptive methods.
        max_energy_growth: stop when |ledger residual| exceeds this many times the
            energy scale max(T0 + |V0|, m |g| 0.1 m); None never stops on energy.
        progress: called with the time reached [s] after every block of steps (compiled loop),
            or with the start time before the first step and then after every step (Python loop;
            a run handed back to it starts again from t = 0). It keeps its own clock
            (``robodyn simulate`` prints a line from it every few seconds of a long run).

    Returns:
        The :class:`Trajectory`, sampled at every step (n_steps + 1 samples).

    Raises:
        InputError: bad vectors (a cos/sin pair or quaternion off the unit sphere
            included), dt, duration, torque or tolerances; backend ``"aba"`` on a model
            with mimic joints; a negative stiffness, a restitution outside [0, 1], a
            coupling cycle, a loop whose frames cannot meet (its residual in m).
        UnknownNameError: an unknown frame or joint in a constraint (with close matches).
        ModelError: M(q0) is singular (a velocity direction that moves no mass or inertia).
        UnknownNameError: an unknown integrator or backend.
        DivergenceError: the run blew up, or its constraint solver failed (the step and
            the residual); ``.trajectory`` holds it up to the failing step.
        SimulationInterrupted: Ctrl-C during the run; ``.trajectory`` holds it so far.
    """
    duration, dt = _check_times(duration, dt)
    method = integrators.get(integrator) if isinstance(integrator, str) else integrator
    spec = _constraint_spec(
        constraints, limits=limits, restitution=restitution, effort_limits=effort_limits, loops=loops,
        couplings=couplings, springs=springs,
    )  # fmt: skip
    if max_energy_growth is not None and not max_energy_growth > 0:
        raise InputError(f"max_energy_growth must be > 0 or None, got {max_energy_growth!r}")
    system = robot_system(robot, backend=backend, torque=torque, losses=losses, constraints=spec)
    start = _initial_state(system, robot, q0, v0, method, dt)
    setup = _Setup(start, method, _time_grid(duration, dt), rtol, atol, max_energy_growth, progress)
    run, check = _first_run(setup)
    run, outcome, wall = _integrate(setup, run, backend)
    loop = _loop_meta(system, outcome)
    handed_back = outcome is not None and not outcome.ran and outcome.steps
    if handed_back and "stiff_friction" in start.notes and run.failure is None:
        loop["compiled_loop"] += (  # handed back mid-run; the Python loop's run is no sounder (exact zeros kept it)
            "; the stiff joint losses of the warning amplify any round-off at every step, and the Python loop "
            "got through only where its round-off is exactly 0"
        )
    meta = _meta(start.robot, system, method, run, dt, duration, check) | start.notes | loop
    impacts = [vars(r) for r in getattr(run.stepper, "impacts", [])]  # the run's record adds them later
    chatter = chattering(meta | {"impact_log": impacts})
    if chatter is not None:
        meta["chattering"] = chatter
    return _result(run, wall, meta)


@dataclass(frozen=True)
class _Start:
    """The run's starting point: the robot as integrated (coupled), its system, (q0, v0) inside the constraints."""

    robot: Robot
    system: RobotSystem
    q: Array
    v: Array
    notes: dict[str, Any]  # what was changed or found on the way, for the metadata


@dataclass(frozen=True)
class _Setup:
    """Everything a :class:`Run` is built from."""

    start: _Start
    method: Integrator
    t_grid: Array
    rtol: float
    atol: float
    max_energy_growth: float | None
    progress: Progress | None = None

    def new_run(self) -> Run:
        """A fresh run from the start (no step taken)."""
        s = self.start
        return Run(
            s.robot, s.system, self.method, self.t_grid, s.q, s.v,
            rtol=self.rtol, atol=self.atol, max_energy_growth=self.max_energy_growth, progress=self.progress,
        )  # fmt: skip


def _constraint_spec(
    constraints: Constraints | None,
    *,
    limits: bool,
    restitution: float,
    effort_limits: bool,
    loops: Sequence[Loop | Mapping[str, Any]],
    couplings: Sequence[Coupling | Mapping[str, Any]],
    springs: Mapping[str, Spring | Mapping[str, Any] | tuple[float, float] | float] | None,
) -> Constraints:
    """The constraints, from ``constraints=`` or from the keyword arguments (not both)."""
    spec = Constraints.build(
        limits=limits,
        restitution=restitution,
        effort_limits=effort_limits,
        loops=loops,
        couplings=couplings,
        springs=springs,
    )
    if constraints is None:
        return spec
    if not spec.is_default:
        raise InputError("give the constraints either as constraints=... or as keyword arguments, not both")
    return constraints


def _initial_state(
    system: RobotSystem, robot: Robot, q0: ArrayLike, v0: ArrayLike, method: Integrator, dt: float
) -> _Start:
    """(q0, v0) checked, mapped to the coupled coordinates, moved inside the constraints; M(q0) checked."""
    notes: dict[str, Any] = {}
    if system.couplings is not None:
        q0, v0, mapped = system.couplings.state(q0, v0)
        notes["state_coupled"] = mapped
        robot = system.robot
    q = configuration(robot, q0)
    v = robot.v_(v0, "v0")
    q, v = _respect_constraints(system, q, v, notes)
    _refuse_singular_mass(robot, system, q)
    stiff = friction_stiffness(system, method, q, dt)
    if stiff is not None:  # the run still happens; the finding is said, in the metadata and by the CLI
        notes["stiff_friction"] = stiff.describe()
    return _Start(robot, system, q, v, notes)


def _first_run(setup: _Setup) -> tuple[Run, energy.EnergyCheck]:
    """The run, with its initial energies (refused when not finite), and the energy cross-check at q0."""
    start = setup.start
    with np.errstate(over="ignore", invalid="ignore"):  # an overflowing state is refused just below
        check = energy.cross_check(start.robot, start.q, start.v)
        run = setup.new_run()
    e0 = (float(run.kinetic[0]), float(run.potential[0]))
    if not np.all(np.isfinite(e0)):  # not a divergence: no step was taken
        raise InputError(
            f"the initial energy is not finite (T0 = {e0[0]:.6g} J, V0 = {e0[1]:.6g} J): q0 or v0 is too large "
            "for float64 arithmetic; expected a state whose energy is a finite number"
        )
    return run, check


def _integrate(setup: _Setup, run: Run, backend: str | None) -> tuple[Run, whole_run.Outcome | None, float]:
    """Take the steps: in the compiled loop where it applies (and ran), else in ``run``'s Python loop.

    Left to its default, a run whose kernels are not built yet takes the Python loop while that
    costs less than compiling them (:mod:`robodyn.sim.compile_choice`).
    Returns the run that holds the steps, the compiled loop's outcome (None: not asked) and the wall time [s].
    """
    system = setup.start.system
    rent = _rent(setup, run) if backend is None else None
    if rent is not None:
        rented = _rented(setup, run, rent)
        if rented is not None:
            return rented
        run = setup.new_run()  # over its budget: the run starts again, compiled
    plan = whole_run.prepare(system, setup.method) if backend in (None, "numba") else None
    start = time.perf_counter()
    outcome = None
    if isinstance(plan, str):
        outcome = whole_run.Outcome(False, plan)
    elif plan is not None:  # the whole run in the compiled loop
        outcome = whole_run.attempt(plan, system, run)
        if not outcome.ran:
            run = setup.new_run()
    if outcome is None or not outcome.ran:
        run.integrate()
    return run, outcome, time.perf_counter() - start


def _rent(setup: _Setup, run: Run) -> compile_choice.Rent | None:
    """The Python loop's budget when this run should not wait for the compiled loop's kernels, else None."""
    system, method = setup.start.system, setup.method
    if whole_run.refusal(system, method) is not None:
        return None
    stages, tableau = whole_run.stages(method)
    return compile_choice.choose(system, run, stages, tableau)


def _rented(setup: _Setup, run: Run, rent: compile_choice.Rent) -> tuple[Run, whole_run.Outcome, float] | None:
    """``run`` in the Python loop within ``rent``'s budget; None when it ran past it (the system as it was, noted)."""
    system = setup.start.system
    held0, evaluations0 = dict(system.held), (system.evaluations, system.jacobian_evaluations)
    run.progress = compile_choice.budgeted(setup.progress, rent.budget)
    start = time.perf_counter()
    try:
        run.integrate()
    except compile_choice.OverBudgetError:
        compile_choice.book(time.perf_counter() - start)
        if system.held != held0:
            system.hold(held0, run.Q[0])
        system.evaluations, system.jacobian_evaluations = evaluations0
        setup.start.notes["python_loop_abandoned"] = (
            f"the Python loop ran past {rent.budget:.3g} s, about what compiling the kernels costs; the run "
            "started again in the compiled loop"
        )
        return None
    wall = time.perf_counter() - start
    compile_choice.book(wall)
    run.progress = setup.progress
    return run, whole_run.Outcome(False, rent.reason), wall


def _result(run: Run, wall: float, meta: dict[str, Any]) -> Trajectory:
    """The trajectory, or the exception that carries it (a divergence, a Ctrl-C)."""
    try:
        trajectory = run.trajectory(wall, meta)
    except KeyboardInterrupt:  # the run is computed: keep it, then answer the Ctrl-C
        trajectory = run.trajectory(wall, meta)
        if run.failure is None and not run.interrupted:
            raise SimulationInterrupted(
                f"interrupted after the last step (t = {float(trajectory.t[-1]):.6g} s)", trajectory=trajectory
            ) from None
    if run.failure is not None:
        step, t_fail, message = run.failure
        raise DivergenceError(message, step=step, time=t_fail, trajectory=trajectory)
    if run.interrupted:
        raise SimulationInterrupted(trajectory.message, trajectory=trajectory)
    return trajectory


def _loop_meta(system: RobotSystem, outcome: whole_run.Outcome | None) -> dict[str, Any]:
    """Which loop ran (``loop``: "compiled" or "python"), the backend it used, and why not the compiled one."""
    if outcome is not None and outcome.ran:
        ran = {"backend": "numba", "loop": "compiled", "compiled_loop": "ran", "event_steps": outcome.event_steps}
        return {**ran, "aba_passes": outcome.passes}
    why = "backend " + system.backend + " asked" if outcome is None else outcome.note
    out: dict[str, Any] = {"backend": system.backend, "loop": "python", "compiled_loop": f"not used: {why}"}
    if outcome is not None and outcome.steps:
        out["compiled_loop_steps"] = outcome.steps  # steps taken compiled before handing back
        out["compiled_loop_wall_time_s"] = outcome.wall_time_s
    return out


def configuration(robot: Robot, q0: ArrayLike) -> Array:
    """q0 as a configuration (nq,); on manifold models nv angles are integrated from neutral.

    Raises:
        InputError: the wrong number of entries, or a cos/sin pair or quaternion whose norm
            is not 1 within ``UNIT_NORM_TOL`` (naming the joint).
    """
    arr = np.asarray(q0, dtype=np.float64).reshape(-1) if not callable(q0) else None
    if arr is not None and robot.nq != robot.nv and arr.size == robot.nv:
        tangent = robot.v_(arr, "q0")
        return dynamics.integrate(robot.model, robot.neutral(), tangent)
    try:
        q = robot.q_(q0)
    except InputError:
        if arr is not None and arr.shape == (robot.nq,):  # the right length: the entries themselves are wrong
            as_vector(arr, robot.nq, "q0")  # raises, naming q0
        if robot.nq != robot.nv:
            raise InputError(
                f"q0 must have {robot.nq} entries (configuration) or {robot.nv} (joint angles) for {robot.name}, "
                f"got {np.size(q0)}"
            ) from None
        raise InputError(f"q0 must have {robot.nq} entries for {robot.name}, got {np.size(q0)}") from None
    check_unit_norms(robot, q, "q0")
    return q


def check_unit_norms(robot: Robot, q: Array, name: str = "q") -> None:
    """Raise :class:`InputError` if a cos/sin pair or quaternion of ``q`` (nq,) is off the unit sphere.

    The tolerance on | |x| - 1 | is ``UNIT_NORM_TOL``; the message names the joint.
    """
    for joint in robot.joints:
        for prefix, lo, hi, what in _UNIT_BLOCKS:
            if joint.kind.startswith(prefix):
                block = q[joint.idx_q + lo : joint.idx_q + hi]
                norm = float(np.linalg.norm(block))
                if not abs(norm - 1.0) <= UNIT_NORM_TOL:
                    values = ", ".join(f"{x:.10g}" for x in block)
                    hint = f" (or give q0 as {robot.nv} joint angles)" if "cos" in what else ""
                    raise InputError(
                        f"{name}: joint {joint.name!r} has the {what} ({values}) of norm {norm:.10g}; "
                        f"it must have norm 1 within {UNIT_NORM_TOL:g}{hint}"
                    )
                break


def _respect_constraints(system: RobotSystem, q: Array, v: Array, notes: dict[str, Any]) -> tuple[Array, Array]:
    """q0 moved inside the stops, then (q0, v0) projected onto the loops; what moved goes to ``notes``.

    Raises:
        InputError: a loop whose frames cannot meet.
    """
    if not system.stops.empty:
        q, moved = system.stops.clamp(q)
        if moved:
            notes["q0_clamped"] = {name: [given, inside] for name, given, inside in moved}
    if system.loops is not None:
        q, v, projection = close_initial_state(system.loops, q, v)
        notes["loop_projection"] = projection
    return q, v


def _refuse_singular_mass(robot: Robot, system: RobotSystem, q: Array) -> None:
    """Raise :class:`ModelError` if M(q) is (numerically) singular: nothing could integrate that."""
    ratio, direction = system.mass_conditioning(q)
    if ratio > SINGULAR_MASS_RTOL:
        return
    raise ModelError(
        f"{robot.name}: the mass matrix M(q0) is singular (smallest eigenvalue {ratio:.2g} of the largest, "
        f"below {SINGULAR_MASS_RTOL:g}): the velocity direction {system.singular_direction(direction)} moves no "
        "mass, inertia or armature (e.g. a thin rod spinning about its own axis); give those links inertia "
        "or lock that motion"
    )


def _check_times(duration: float, dt: float) -> tuple[float, float]:
    for name, value in (("duration", duration), ("dt", dt)):
        if not is_number(value) or value <= 0:
            raise InputError(f"{name} must be a positive number of seconds, got {reprlib.repr(value)}")
    if dt > duration:
        raise InputError(f"dt must not exceed duration ({duration:g} s), got {dt:g} s")
    if duration / dt > MAX_STEPS:
        raise InputError(f"duration / dt = {duration / dt:.3g} steps; at most {MAX_STEPS:.0e} are allowed")
    return float(duration), float(dt)


def _time_grid(duration: float, dt: float) -> Array:
    """t_k = k dt up to ``duration``; a last, shorter step lands exactly on it."""
    n = int(np.ceil(duration / dt - 1e-9))
    t = dt * np.arange(n + 1, dtype=np.float64)
    t[-1] = duration
    return t


def _meta(
    robot: Robot,
    system: RobotSystem,
    method: Integrator,
    run: Run,
    dt: float,
    duration: float,
    check: energy.EnergyCheck,
) -> dict[str, Any]:
    q_units, v_units = coordinate_units(robot)
    meta: dict[str, Any] = {
        "model": robot.name,
        "urdf": str(robot.urdf_path) if robot.urdf_path is not None else None,
        "srdf": str(robot.srdf_path) if robot.srdf_path is not None else None,
        "integrator": method.name,
        "order": method.order,
        "symplectic": method.symplectic,
        "adaptive": method.adaptive,
        "implicit": method.implicit,
        "dt": dt,
        "duration": duration,
        "q0": run.Q[0].tolist(),
        "v0": run.U[0, : system.nv].tolist(),
        "energy_scale": run.scale,
        "energy_bound": None if not np.isfinite(run.bound) else run.bound,
        "energy_cross_check": check.relative_error,
        "joint_names": list(robot.joint_names),
        "q_units": q_units,
        "v_units": v_units,
    }
    meta.update(system.describe())
    if method.adaptive:
        meta["rtol"], meta["atol"] = run.rtol, run.atol
        meta["accepted_steps"] = getattr(run.stepper, "steps", None)
        meta["rejected_steps"] = getattr(run.stepper, "rejected", None)
    if run.failure is not None:
        meta["diverged_step"], meta["diverged_time"] = run.failure[0], run.failure[1]
    if run.interrupted is not None:
        meta["interrupted_step"], meta["interrupted_time"] = run.interrupted[0], run.interrupted[1]
    return meta
