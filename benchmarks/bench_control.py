"""Swing up and balance: the evidence for robodyn.control on the cart-pole and the Pendubot.

For both systems, measured in one run:

* the linearisation at the upright: Robot.linearize (Pinocchio's analytic ABA derivatives)
  against the closed form differentiated by sympy and against central finite differences of
  the forward dynamics (step FD_STEP), as max |difference| / max |reference|;
* the LQR: gain, closed-loop poles, and the region of attraction it hands over in;
* swing-up from hanging at rest (robodyn.simulate, RK4, dt = DT): the time to reach upright and
  stay within SETTLE_TOL rad, the peak torque against the URDF's effort limit, the energy against
  its target, and (cart-pole) the cart's largest excursion against the rail;
* the LQR's basin: a GRID x GRID grid of initial states (cart-pole: theta, theta' with the cart
  at rest in the middle; Pendubot: q1, q2 at rest), each run for BASIN_SECONDS under the
  saturated LQR by the vectorised closed-loop RK4 (robodyn.control.rollout, "fast" backend),
  with the "aba" backend timed on a subset and checked to agree;
* robustness: the controllers designed on the nominal model, run on models whose masses are
  off by -20 %, 0 and +20 % (a density error: mass and rotational inertia scaled together),
  written by robodyn.kinds.edit.write_params into a temporary folder; the success rate.

    python benchmarks/bench_control.py --out bench-out

prints everything and writes control.json (with the date, machine and load of the run) and
control_<system>.png / _basin.png (+ .svg) to --out (default bench-out/). ``--quick`` runs a
5 x 5 basin grid and the nominal masses only, to show the script works.
"""

from __future__ import annotations

import itertools
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

import robodyn
import robodyn.control as control
from robodyn.control import rollout, symbolic
from robodyn.control.plant import wrap
from robodyn.kinds import edit, params

from _common import argument_parser, output_folder, pyplot, run_facts, save_figure, write_json

DT = 2e-3  # [s] RK4 step of every run
SETTLE_TOL = 0.05  # [rad] "upright": every angle within this of upright, and staying there
FD_STEP = 1e-6  # central finite-difference step on x and u
GRID = 41
BASIN_SECONDS = 10.0
BALANCED_TOL = 0.05  # [rad | m | rad/s | m/s] every coordinate and velocity at the end of a basin run
MASS_FACTORS = (0.8, 1.0, 1.2)
SWING_SECONDS = {"cart_pole": 15.0, "pendubot": 40.0}
HOLD_SECONDS = 3.0  # a robust run succeeds when it is upright and stays for at least this long before the end
MASSES = {"cart_pole": (("m_cart",), ("m", "I")), "pendubot": (("m1", "I1"), ("m2", "I2"))}
SYSTEMS = ("cart_pole", "pendubot")


def settle_time(t: np.ndarray, error: np.ndarray, tol: float) -> float | None:
    """The first time after which ``error`` (n,) stays below ``tol``, or None if it ends above."""
    bad = np.flatnonzero(~(error < tol))
    if bad.size == 0:
        return float(t[0])
    return float(t[bad[-1] + 1]) if bad[-1] + 1 < t.size else None


def angle_error(ctl: control.Switched, q: np.ndarray) -> np.ndarray:
    """Largest wrapped angle error from upright (n,) [rad]."""
    plant = ctl.lqr.plant
    return np.max(np.abs(wrap(q[:, plant.angular] - ctl.lqr.q_eq[plant.angular])), axis=1)


def finite_differences(robot: robodyn.Robot, q: np.ndarray, u: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) by central differences of f(x, u) = [v, a(q, v, S u - D v)] at (q, 0, u)."""
    n, S = robot.nv, robot.input_matrix()

    def f(x: np.ndarray, uu: np.ndarray) -> np.ndarray:
        return np.r_[x[n:], robot.forward_dynamics(x[:n], x[n:], S @ uu - robot.damping * x[n:])]

    x0 = np.r_[q, np.zeros(n)]
    A = np.column_stack([(f(x0 + h * e, u) - f(x0 - h * e, u)) / (2 * h) for e in np.eye(2 * n)])
    B = np.column_stack([(f(x0, u + h * e) - f(x0, u - h * e)) / (2 * h) for e in np.eye(u.size)])
    return A, B


def seconds(t: float | None) -> str:
    """``3.412 s``, or ``never`` for None."""
    return "never" if t is None else f"{t:.3f} s"


def relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def linearisation(robot: robodyn.Robot, ctl: control.Switched) -> dict[str, Any]:
    q, u = ctl.lqr.q_eq, ctl.lqr.u_eq
    A, B = robot.linearize(q, np.zeros(robot.nv), u)
    kind = ctl.lqr.plant.kind
    start = time.perf_counter()
    As, Bs = symbolic.linearize(
        kind, params.extract(robot, kind), q, actuated=robot.actuated, u_eq=u, damping=robot.damping
    )
    sympy_s = time.perf_counter() - start
    Af, Bf = finite_differences(robot, q, u, FD_STEP)
    return {
        "A": A.tolist(),
        "B": B.tolist(),
        "vs_sympy": {"A": relative(A, As), "B": relative(B, Bs), "sympy_seconds": sympy_s},
        "vs_finite_differences": {"A": relative(A, Af), "B": relative(B, Bf), "step": FD_STEP},
    }


def swing_up(robot: robodyn.Robot, ctl: control.Switched, duration: float) -> tuple[dict[str, Any], Any]:
    plant = ctl.lqr.plant
    start = time.perf_counter()
    traj = robodyn.simulate(robot, plant.hanging(), np.zeros(robot.nv), duration=duration, dt=DT, torque=ctl)
    wall = time.perf_counter() - start
    modes = ctl.modes(traj.q, traj.v)
    energy = np.array([ctl.swing_up.energy(q, v) for q, v in zip(traj.q, traj.v, strict=True)])
    t_up = settle_time(traj.t, angle_error(ctl, traj.q), SETTLE_TOL)
    u = traj.tau[:, robot.actuated]
    out = {
        "duration_s": duration,
        "dt_s": DT,
        "wall_time_s": wall,
        "time_to_upright_s": t_up,
        "hand_over_s": float(traj.t[np.argmax(modes == 1)]) if np.any(modes == 1) else None,
        "peak_torque": float(np.max(np.abs(u))),
        "effort_limit": float(plant.effort[0]),
        "energy_target_J": ctl.swing_up.energy_up,
        "energy_final_J": float(energy[-1]),
        "energy_peak_J": float(np.max(energy)),
    }
    if plant.rail_index is not None:
        limits = robot.model.lowerPositionLimit[plant.rail_index], robot.model.upperPositionLimit[plant.rail_index]
        out["cart_max_abs_m"] = float(np.max(np.abs(traj.q[:, plant.rail_index])))
        out["rail_m"] = [float(limits[0]), float(limits[1])]
        out["rail_usable_m"] = list(plant.rail)
    return out, (traj, energy, modes)


def basin(robot: robodyn.Robot, ctl: control.Switched) -> dict[str, Any]:
    lqr, plant = ctl.lqr, ctl.lqr.plant
    n = robot.nv
    if plant.kind == "cart_pole":
        axes = ("theta [rad]", "theta' [rad/s]")
        a, b = np.linspace(-1.5, 1.5, GRID), np.linspace(-6.0, 6.0, GRID)
        A_, B_ = np.meshgrid(a, b, indexing="ij")
        q0 = np.c_[np.zeros(A_.size), A_.ravel()]
        v0 = np.c_[np.zeros(A_.size), B_.ravel()]
        plane = (1, n + 1)
    else:
        axes = ("q1 - pi/2 [rad]", "q2 [rad]")
        a, b = np.linspace(-0.8, 0.8, GRID), np.linspace(-1.6, 1.6, GRID)
        A_, B_ = np.meshgrid(a, b, indexing="ij")
        q0 = np.c_[lqr.q_eq[0] + A_.ravel(), B_.ravel()]
        v0 = np.zeros_like(q0)
        plane = (0, 1)
    fast = rollout.closed_loop(robot, lqr.batch, q0, v0, duration=BASIN_SECONDS, dt=DT, backend="fast")
    ok = balanced(robot, lqr, fast)
    subset = np.arange(0, q0.shape[0], max(1, q0.shape[0] // 60))
    slow = rollout.closed_loop(robot, lqr.batch, q0[subset], v0[subset], duration=BASIN_SECONDS, dt=DT, backend="aba")
    agree = float(np.nanmax(np.abs(slow.q - fast.q[subset]))) if np.all(np.isfinite(slow.q)) else float("nan")
    inside = np.asarray(lqr.value(q0, v0) < ctl.region.rho)
    return {
        "axes": axes,
        "a": a.tolist(),
        "b": b.tolist(),
        "plane": plane,
        "balanced": ok.reshape(GRID, GRID).tolist(),
        "fraction_balanced": float(np.mean(ok)),
        "fraction_in_region": float(np.mean(inside)),
        "region_states_balanced": float(np.mean(ok[inside])) if np.any(inside) else None,
        "seconds": BASIN_SECONDS,
        "fast_wall_s": fast.wall_time_s,
        "fast_state_steps_per_s": q0.shape[0] * fast.steps / fast.wall_time_s,
        "aba_wall_s_subset": slow.wall_time_s,
        "aba_state_steps_per_s": subset.size * slow.steps / slow.wall_time_s,
        "aba_vs_fast_max_abs_q": agree,
    }


def balanced(robot: robodyn.Robot, lqr: control.LQR, run: rollout.Rollout) -> np.ndarray:
    plant = lqr.plant
    e = plant.error(run.q, run.v, lqr.q_eq)
    ok = np.all(np.abs(e) < BALANCED_TOL, axis=1) & np.all(np.isfinite(e), axis=1)
    if plant.rail_index is not None:
        k = plant.rail_index
        ok &= (run.q_min[:, k] >= robot.model.lowerPositionLimit[k]) & (
            run.q_max[:, k] <= robot.model.upperPositionLimit[k]
        )
    return np.asarray(ok)


def robustness(robot: robodyn.Robot, ctl: control.Switched, folder: Path) -> dict[str, Any]:
    kind = ctl.lqr.plant.kind
    p = params.extract(robot, kind)
    first, second = MASSES[kind]
    duration = SWING_SECONDS[kind]
    runs = []
    for f1, f2 in itertools.product(MASS_FACTORS, MASS_FACTORS):
        changes = {name: p[name] * f1 for name in first} | {name: p[name] * f2 for name in second}
        written = edit.write_params(robot, kind, changes, folder / f"{kind}_{f1:g}_{f2:g}.urdf")
        plant_robot = robodyn.load(str(written.urdf))
        traj = robodyn.simulate(
            plant_robot, ctl.lqr.plant.hanging(), np.zeros(robot.nv), duration=duration, dt=DT, torque=ctl
        )
        t_up = settle_time(traj.t, angle_error(ctl, traj.q), SETTLE_TOL)
        success = t_up is not None and t_up <= duration - HOLD_SECONDS
        runs.append({"factors": [f1, f2], "time_to_upright_s": t_up, "success": bool(success)})
        print(f"    {kind} masses x ({f1:g}, {f2:g}): upright at {seconds(t_up)}, {'ok' if success else 'FAILED'}")
    wins = sum(r["success"] for r in runs)
    return {
        "parameters": [list(first), list(second)],
        "factors": list(MASS_FACTORS),
        "duration_s": duration,
        "hold_s": HOLD_SECONDS,
        "runs": runs,
        "success_rate": wins / len(runs),
        "successes": f"{wins}/{len(runs)}",
    }


def draw_swing_up(name: str, data: tuple[Any, np.ndarray, np.ndarray], result: dict[str, Any], out: Path) -> None:
    plt = pyplot()
    traj, energy, _modes = data
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    for j, joint in enumerate(traj.meta.get("joint_names", [f"q{k + 1}" for k in range(traj.q.shape[1])])):
        axes[0].plot(traj.t, traj.q[:, j], label=joint)
    axes[0].set_ylabel("q [rad | m]")
    axes[0].legend(loc="upper right")
    tau = traj.tau[:, np.flatnonzero(np.any(traj.tau != 0, axis=0))] if np.any(traj.tau) else traj.tau[:, :1]
    axes[1].plot(traj.t, tau, color="C3")
    for sign in (1, -1):
        axes[1].axhline(sign * result["effort_limit"], color="k", ls="--", lw=0.8)
    axes[1].set_ylabel("torque [N m | N]")
    axes[2].plot(traj.t, energy, label="energy")
    axes[2].axhline(result["energy_target_J"], color="k", ls="--", lw=0.8, label="target E_up")
    axes[2].set_ylabel("swing-up energy [J]")
    axes[2].set_xlabel("t [s]")
    axes[2].legend(loc="lower right")
    for ax in axes:
        if result["hand_over_s"] is not None:
            ax.axvline(result["hand_over_s"], color="C2", lw=0.8)
    t_up = result["time_to_upright_s"]
    fig.suptitle(
        f"{name}: swing-up from hanging, upright (within {SETTLE_TOL} rad) at "
        f"{t_up if t_up is None else round(t_up, 3)} s"
    )
    fig.tight_layout()
    save_figure(fig, out, f"control_{name}")


def draw_basin(name: str, ctl: control.Switched, result: dict[str, Any], out: Path) -> None:
    plt = pyplot()
    a, b = np.array(result["a"]), np.array(result["b"])
    ok = np.array(result["balanced"], dtype=float)
    fig, ax = plt.subplots(figsize=(6, 5))
    ax.pcolormesh(a, b, ok.T, cmap="Greens", vmin=0, vmax=1.4, shading="nearest")
    i, j = result["plane"]
    P = ctl.lqr.P
    A_, B_ = np.meshgrid(a, b, indexing="ij")
    V = P[i, i] * A_**2 + 2 * P[i, j] * A_ * B_ + P[j, j] * B_**2
    ax.contour(a, b, V.T, levels=[ctl.region.rho], colors="C3")
    ax.set_xlabel(result["axes"][0])
    ax.set_ylabel(result["axes"][1])
    ax.set_title(
        f"{name}: LQR balances {100 * result['fraction_balanced']:.1f} % of the grid (green);\n"
        f"red: the hand-over region e^T P e < {ctl.region.rho:.3g} in this plane"
    )
    fig.tight_layout()
    save_figure(fig, out, f"control_{name}_basin")


def main() -> None:
    global GRID, MASS_FACTORS
    parser = argument_parser(__doc__)
    parser.add_argument(
        "--quick",
        action="store_true",
        help="a small run that shows the script works (5 x 5 basin grid, nominal masses only): not figures to quote",
    )
    args = parser.parse_args()
    if args.quick:
        GRID, MASS_FACTORS = 5, (1.0,)
    out = output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()
    report: dict[str, Any] = {"dt_s": DT, "settle_tol_rad": SETTLE_TOL, "quick": args.quick}
    with tempfile.TemporaryDirectory(prefix="bench_control_models-") as models:
        for name in SYSTEMS:
            robot = robodyn.load(name)
            ctl = control.make("swing_up", robot)
            lin = linearisation(robot, ctl)
            print(f"{name}: linearisation at the upright q = {np.round(ctl.lqr.q_eq, 6).tolist()}")
            print(
                f"  A, B vs sympy: max rel diff {lin['vs_sympy']['A']:.2e}, {lin['vs_sympy']['B']:.2e}; "
                f"vs central differences (h = {FD_STEP:g}): {lin['vs_finite_differences']['A']:.2e}, "
                f"{lin['vs_finite_differences']['B']:.2e}"
            )
            lqr = {
                "K": ctl.lqr.K.tolist(),
                "poles": [[float(z.real), float(z.imag)] for z in ctl.lqr.poles],
                "region": ctl.region.describe(),
                "rho": ctl.region.rho,
            }
            print(f"  LQR K = {np.round(ctl.lqr.K, 3).tolist()}, poles {np.round(ctl.lqr.poles, 3).tolist()}")
            print(f"  hand-over region: {ctl.region.describe()}")
            swing, data = swing_up(robot, ctl, SWING_SECONDS[name])
            print(
                f"  swing-up from hanging: upright (within {SETTLE_TOL} rad, staying) at "
                f"{seconds(swing['time_to_upright_s'])} "
                f"(hand-over at {seconds(swing['hand_over_s'])}); peak torque {swing['peak_torque']:.3f} of "
                f"{swing['effort_limit']:g} allowed; energy {swing['energy_final_J']:.4f} J vs target "
                f"{swing['energy_target_J']:.4f} J"
                + (
                    f"; cart within {swing['cart_max_abs_m']:.3f} m of centre (rail +-{swing['rail_m'][1]:g} m)"
                    if "cart_max_abs_m" in swing
                    else ""
                )
            )
            draw_swing_up(name, data, swing, out)
            area = basin(robot, ctl)
            print(
                f"  LQR basin ({GRID} x {GRID} grid of {area['axes'][0]}, {area['axes'][1]}; {BASIN_SECONDS:g} s): "
                f"{100 * area['fraction_balanced']:.1f} % balance; {100 * area['fraction_in_region']:.1f} % lie in "
                f"the hand-over region, of which {100 * (area['region_states_balanced'] or 0):.1f} % balance"
            )
            print(
                f"  batch rollout: fast {area['fast_state_steps_per_s']:.3g} state-steps/s, aba "
                f"{area['aba_state_steps_per_s']:.3g}; they agree to {area['aba_vs_fast_max_abs_q']:.2e} in q"
            )
            draw_basin(name, ctl, area, out)
            print("  robustness (mass and inertia scaled together):")
            robust = robustness(robot, ctl, Path(models))
            print(f"  success {robust['successes']} ({100 * robust['success_rate']:.0f} %)")
            report[name] = {"linearisation": lin, "lqr": lqr, "swing_up": swing, "basin": area, "robustness": robust}
    path = write_json(out, "control", report, facts)
    print(f"wrote {path} and the charts to {out}")


if __name__ == "__main__":
    main()
