"""The constraint engine's figures: step cost, impact loss, loop drift, the Panda inside its limits.

    python benchmarks/bench_constraints.py [--repeat 3] [--out DIR]

Prints, and saves as ``DIR/constraints.json`` (DIR defaults to a fresh temporary folder,
never the repository):

* **cost** -- wall time per step (best of ``--repeat``, RK4, dt = 1e-3) of an unconstrained
  run against: the same run watching stops that are never reached; a cart held at its rail
  end; the 19.3 linkage closed by its loop (Pinocchio's constraintDynamics + projection)
  against the same tree left open; and one ``constraintDynamics`` call against one ``aba``;
* **impact** -- the energy the rail's end takes from the cart-pole, booked by the run,
  against 1/2 (J v)^2 / (J M^-1 J^T) (1 - e^2) at the impact state found by SciPy's DOP853
  with event location (no robodyn code in the oracle);
* **loop** -- the 19.3 linkage released from rest (with its torsional spring): the worst
  loop drift [m] with projection and with Baumgarte alone, and the worst |omega^2 - book|
  relative to the largest omega^2;
* **panda** -- ``robodyn.simulate(robodyn.load("panda"), ...)`` torque-free for 2 s from
  the neutral configuration: the worst excursion past a limit with stops, and where the
  fingers end without them.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
from scipy.integrate import solve_ivp

import robodyn
from robodyn import constrained
from robodyn.sim import events, loops
from robodyn.sim.simulation import simulate

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from test_constraints import LOOP, book_omega2, closed, linkage_urdf

DT = 1e-3
K_SPRING = 5.0
THETA0 = 0.3


def per_step(run: Any, repeat: int) -> tuple[float, Any]:
    """Best wall time per step [s] of ``run()`` (a Trajectory) over ``repeat`` calls."""
    best, result = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        result = run()
        best = min(best, (time.perf_counter() - start) / result.n_steps)
    return best, result


def call_cost(fn: Any, n: int = 2000) -> float:
    """Best-of-3 wall time of one ``fn()`` call [s]."""
    best = float("inf")
    for _ in range(3):
        start = time.perf_counter()
        for _ in range(n):
            fn()
        best = min(best, (time.perf_counter() - start) / n)
    return best


def cost(linkage: robodyn.Robot, repeat: int) -> dict[str, float]:
    pendubot, cart = robodyn.load("pendubot"), robodyn.load("cart_pole")
    state = ([0.3, -0.2], [0.5, -1.0])
    free, _ = per_step(lambda: simulate(pendubot, *state, duration=1.0, dt=DT, limits=False), repeat)
    watched, _ = per_step(lambda: simulate(pendubot, *state, duration=1.0, dt=DT), repeat)
    cart_free, _ = per_step(lambda: simulate(cart, [2.4, 0.0], [0.0, 0.0], duration=1.0, dt=DT, limits=False), repeat)
    held, traj = per_step(lambda: simulate(cart, [2.4, 0.0], [0.0, 0.0], duration=1.0, dt=DT, torque=[2.0]), repeat)
    assert traj.meta["held_at_end"] == ["slider"]
    q0 = closed(THETA0)
    open_tree, _ = per_step(lambda: simulate(linkage, q0, [0, 0, 0], duration=0.5, dt=DT, limits=False), repeat)
    closed_loop, _ = per_step(lambda: simulate(linkage, q0, [0, 0, 0], duration=0.5, dt=DT, loops=LOOP), repeat)
    model = linkage.model
    a, b = constrained.anchor(model, "bc_tip"), constrained.anchor(model, "collar")
    assert a is not None and b is not None
    solver = constrained.ConstraintSolver(model, [constrained.loop_model(model, "point", a, b, 100.0, 20.0)])
    q, v, tau = np.array(q0), np.zeros(3), np.zeros(3)
    data = model.createData()
    return {
        "free_step_s": free,
        "watching_stops_step_s": watched,
        "watching_overhead": watched / free,
        "cart_free_step_s": cart_free,
        "cart_held_step_s": held,
        "held_overhead": held / cart_free,
        "open_tree_step_s": open_tree,
        "closed_loop_step_s": closed_loop,
        "loop_overhead": closed_loop / open_tree,
        "constraint_dynamics_call_s": call_cost(lambda: solver.acceleration(q, v, tau)),
        "aba_call_s": call_cost(lambda: pin.aba(model, data, q, v, tau)),
    }


def impact() -> list[dict[str, float]]:
    robot = robodyn.load("cart_pole")
    q0, v0 = [2.0, 0.1], [1.0, 0.0]
    tau = np.zeros(2)

    def fun(_: float, y: np.ndarray) -> np.ndarray:
        return np.concatenate([y[2:], robot.forward_dynamics(y[:2], y[2:], tau)])

    def hit(_: float, y: np.ndarray) -> float:
        return float(y[0] - 2.4)

    hit.terminal = True  # type: ignore[attr-defined]
    sol = solve_ivp(fun, (0, 2), np.array(q0 + v0), method="DOP853", rtol=1e-12, atol=1e-12, events=hit)
    y = sol.y_events[0][0]
    J = np.array([-1.0, 0.0])
    delassus = float(J @ np.linalg.inv(robot.M(y[:2])) @ J)
    rows = []
    for e in (0.0, 0.5, 0.9):
        traj = simulate(robot, q0, v0, duration=1.0, dt=DT, restitution=e)
        first = traj.meta["impact_log"][0]
        analytic = 0.5 * float(J @ y[2:]) ** 2 / delassus * (1 - e**2)
        booked = -first["energy_change"]
        rows.append(
            {
                "restitution": e,
                "booked_J": booked,
                "analytic_J": analytic,
                "relative_difference": abs(booked - analytic) / analytic if analytic else abs(booked),
                "impact_time_error_s": abs(first["time"] - float(sol.t_events[0][0])),
                "max_ledger_residual_J": traj.max_ledger_residual,
            }
        )
    return rows


def loop(linkage: robodyn.Robot) -> dict[str, float]:
    springs = {"joint_a": (K_SPRING, 0.0)}
    traj = simulate(linkage, closed(THETA0), [0, 0, 0], duration=2.0, dt=DT, loops=LOOP, springs=springs)
    expected = book_omega2(traj.q[:, 1], THETA0, K_SPRING)
    saved = events.PROJECT_ABOVE
    events.PROJECT_ABOVE = np.inf
    try:
        baumgarte = simulate(linkage, closed(THETA0), [0, 0, 0], duration=2.0, dt=DT, loops=LOOP, springs=springs)
    finally:
        events.PROJECT_ABOVE = saved
    return {
        "omega2_relative_error": float(np.max(np.abs(traj.v[:, 1] ** 2 - expected)) / np.max(expected)),
        "drift_with_projection_m": traj.meta["loop_drift"],
        "projections": traj.meta["loop_projections"],
        "drift_baumgarte_only_m": baumgarte.meta["loop_drift"],
        "baumgarte_gains": [loops.KP, loops.KD],
        "max_ledger_residual_J": traj.max_ledger_residual,
    }


def panda() -> dict[str, Any]:
    robot = robodyn.load("panda")
    start = time.perf_counter()
    traj = simulate(robot, robot.neutral(), np.zeros(robot.nv), duration=2.0, dt=DT)
    wall = time.perf_counter() - start
    lower, upper = np.array(robot.model.lowerPositionLimit), np.array(robot.model.upperPositionLimit)
    free = simulate(robot, robot.neutral(), np.zeros(robot.nv), duration=2.0, dt=DT, limits=False)
    return {
        "worst_violation": float(np.max(np.maximum(lower - traj.q, traj.q - upper))),
        "impacts": traj.meta["impacts"],
        "releases": traj.meta["releases"],
        "work_limits_J": float(traj.work_limits[-1]),
        "max_ledger_residual_J": traj.max_ledger_residual,
        "energy_scale_J": traj.meta["energy_scale"],
        "q0_clamped": traj.meta.get("q0_clamped"),
        "wall_time_s": wall,
        "fingers_final_m": traj.q[-1, 7:].tolist(),
        "fingers_final_without_limits_m": free.q[-1, 7:].tolist(),
        "worst_violation_without_limits": float(np.max(np.maximum(lower - free.q, free.q - upper))),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", type=Path, default=None, help="folder for constraints.json (default: a temp folder)")
    args = parser.parse_args()
    out = args.out if args.out is not None else Path(tempfile.mkdtemp(prefix="bench-constraints-"))
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        linkage = robodyn.load(linkage_urdf(Path(tmp) / "linkage.urdf"))
        result = {
            "machine": platform.platform(),
            "cost": cost(linkage, args.repeat),
            "impact": impact(),
            "loop": loop(linkage),
            "panda": panda(),
        }
    c, lp, p = result["cost"], result["loop"], result["panda"]
    print(f"cost per RK4 step (dt = 1 ms, best of {args.repeat}):")
    print(
        f"  pendubot free {c['free_step_s'] * 1e6:.1f} us; watching unreached stops "
        f"{c['watching_stops_step_s'] * 1e6:.1f} us (x{c['watching_overhead']:.2f})"
    )
    print(
        f"  cart-pole free {c['cart_free_step_s'] * 1e6:.1f} us; held at its rail end "
        f"{c['cart_held_step_s'] * 1e6:.1f} us (x{c['held_overhead']:.2f})"
    )
    print(
        f"  19.3 linkage open {c['open_tree_step_s'] * 1e6:.1f} us; closed by its loop "
        f"{c['closed_loop_step_s'] * 1e6:.1f} us (x{c['loop_overhead']:.2f})"
    )
    print(
        f"  one constraintDynamics call {c['constraint_dynamics_call_s'] * 1e6:.1f} us; one aba "
        f"{c['aba_call_s'] * 1e6:.1f} us"
    )
    print(
        "energy lost at the cart-pole's rail end (booked vs 1/2 (J v)^2 / (J M^-1 J^T) (1 - e^2) at DOP853's impact):"
    )
    for row in result["impact"]:
        print(
            f"  e = {row['restitution']:.1f}: {row['booked_J']:.12f} J vs {row['analytic_J']:.12f} J "
            f"(relative {row['relative_difference']:.1e}; impact time off by {row['impact_time_error_s']:.1e} s; "
            f"ledger {row['max_ledger_residual_J']:.1e} J)"
        )
    print(
        f"19.3 linkage, 2 s at 1 ms: omega^2 vs the book {lp['omega2_relative_error']:.1e} of its max; loop drift "
        f"{lp['drift_with_projection_m']:.1e} m with projection ({lp['projections']} projections), "
        f"{lp['drift_baumgarte_only_m']:.1e} m with Baumgarte alone (Kp, Kd = {lp['baumgarte_gains']})"
    )
    print(
        f"Panda torque-free 2 s from neutral: worst excursion past a limit {p['worst_violation']:.1e} "
        f"({p['impacts']} impacts, {p['releases']} releases, W_limits {p['work_limits_J']:.3f} J, ledger "
        f"{p['max_ledger_residual_J']:.1e} J, {p['wall_time_s']:.2f} s wall); without stops "
        f"{p['worst_violation_without_limits']:.2f} past, fingers at "
        f"{np.round(p['fingers_final_without_limits_m'], 2)} m"
    )
    path = out / "constraints.json"
    path.write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
