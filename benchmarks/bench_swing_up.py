"""Swing-up robustness: families of Pendubots and cart-poles a user could bring, each swung up and judged.

Each family draws ``--n`` systems (seeded): every mass, length and inertia scaled by its own
factor drawn log-uniformly over 0.3x to 3x of a base model (the built-in one, or for the Pendubot
also the Spong-Block one; the centre of mass kept inside its link), and an effort limit drawn
log-uniformly from generous to too small (in units of what the swing needs,
:func:`robodyn.control.swing_up.swing_need`: ``EFFORT_RANGE``). Every system gets the controller
``robodyn.control.make("swing_up", robot)`` builds from its own model, and runs for ``DURATION``
from hanging at rest and from a random state. The whole family runs at once in one vectorised RK4
(:func:`robodyn.control.rollout.closed_loop_family`: the torque laws the GPU compiles and the
kinds' closed forms, element-wise), and each run is judged by :mod:`robodyn.control.outcome`: the
decision the CLI's summary and the sweep's ``time_to_balance`` read.

Reported per family and start: the share that balanced, the share of those whose effort allows
it (above the need) that balanced, the share that did not and gave a reason, the time to balance
and the peak torque (median, max). A Pendubot run also fails when its elbow swept beyond the
+-100 rad joint limits of the Spong-Block file.

    python benchmarks/bench_swing_up.py --out bench-out

writes swing_up.json and swing_up.png/.svg; ``--n 20`` for a quick look. Each family is drawn from
its own seed (``FAMILY_SEED`` plus ``--seed``), so ``--families`` picks families without changing
their systems, and

    python benchmarks/bench_swing_up.py --only "pendubot (Spong-Block):88"

runs system 88 of that family as the whole run draws it (``--n`` keeps the draw), from both starts,
and prints each run's outcome (no JSON or chart).
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

import numpy as np

import robodyn
import robodyn.control as control
from robodyn.control import outcome, rollout
from robodyn.control.compiled import law_of
from robodyn.control.swing_up import NEED_CART_POLE, swing_need
from robodyn.kinds.catalog import closed_form
from robodyn.sim.fast import FastDynamics

from _common import argument_parser, output_folder, pyplot, run_facts, save_figure, write_json

DURATION = 30.0  # [s] every run
DT = 1e-3  # [s] RK4 step, as `robodyn simulate`'s default
SCALE = (0.3, 3.0)  # each parameter's factor, log-uniform
EFFORT_RANGE = (0.3, 30.0)  # effort / need, log-uniform: a third of the need to thirty times it
G = 9.81  # [m/s^2] robodyn's gravity
ELBOW_LIMIT = 100.0  # [rad] the Spong-Block file's joint limits
# Each family's seed, added to --seed: the same draws whichever families a run picks.
FAMILY_SEED = {"pendubot (built-in)": 0, "pendubot (Spong-Block)": 1, "cart_pole (built-in)": 20}
BASES = {
    "pendubot (built-in)": ("pendubot", dict(m1=1.336, m2=0.5, l1=0.15, lc1=0.10, lc2=0.126, I1=6.19e-3, I2=2.6502e-3)),
    "pendubot (Spong-Block)": (
        "pendubot",
        dict(m1=1.2185, m2=0.4992, l1=0.1508, lc1=0.1094, lc2=0.1262, I1=0.00486, I2=0.00265),
    ),
    "cart_pole (built-in)": ("cart_pole", dict(m_cart=1.0, m=0.1, l=0.5, I=8.3333333e-3)),
}

PENDUBOT = """<robot name="p"><link name="base"/>
<link name="link1"><inertial><origin xyz="{lc1} 0 0"/><mass value="{m1}"/>
<inertia ixx="1e-6" iyy="{I1}" izz="{I1}" ixy="0" ixz="0" iyz="0"/></inertial></link>
<link name="link2"><inertial><origin xyz="{lc2} 0 0"/><mass value="{m2}"/>
<inertia ixx="1e-6" iyy="{I2}" izz="{I2}" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="joint1" type="revolute"><parent link="base"/><child link="link1"/><axis xyz="0 -1 0"/>
<limit lower="-100" upper="100" effort="{effort}" velocity="100"/></joint>
<joint name="joint2" type="revolute"><parent link="link1"/><child link="link2"/><origin xyz="{l1} 0 0"/>
<axis xyz="0 -1 0"/><limit lower="-100" upper="100" effort="0" velocity="100"/></joint></robot>"""

CART_POLE = """<robot name="c"><link name="world"/>
<link name="cart"><inertial><mass value="{m_cart}"/>
<inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
<link name="pole"><inertial><origin xyz="0 0 {l}"/><mass value="{m}"/>
<inertia ixx="{I}" iyy="{I}" izz="1e-6" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="slider" type="prismatic"><parent link="world"/><child link="cart"/><axis xyz="1 0 0"/>
<limit lower="-2.4" upper="2.4" effort="{effort}" velocity="100"/></joint>
<joint name="hinge" type="revolute"><parent link="cart"/><child link="pole"/><axis xyz="0 1 0"/>
<limit lower="-1000" upper="1000" effort="0" velocity="100"/></joint></robot>"""


def draw(base: dict[str, float], kind: str, rng: np.random.Generator) -> dict[str, float]:
    """One system: every parameter scaled by its own factor in SCALE; a centre of mass kept inside its link."""
    lo, hi = np.log(SCALE[0]), np.log(SCALE[1])
    p = {name: value * float(np.exp(rng.uniform(lo, hi))) for name, value in base.items()}
    if kind == "pendubot":
        p["lc1"] = min(p["lc1"], p["l1"])  # link 1's centre of mass on the link
    return p


def build(kind: str, p: dict[str, float], effort: float, folder: Path, k: int) -> Any:
    """(robot, controller, need [N m | N], c, params, damping) of one drawn system."""
    text = (PENDUBOT if kind == "pendubot" else CART_POLE).format(
        effort=repr(effort), **{n: repr(v) for n, v in p.items()}
    )
    path = folder / f"{kind}_{k}.urdf"
    path.write_text(text)
    passive = ["joint2"] if kind == "pendubot" else ["hinge"]
    robot = robodyn.load(path, passive=passive)
    controller = control.make("swing_up", robot)
    form = closed_form(kind)
    values = {name: robot_params(robot, kind)[name] for name in form.params}
    fast = FastDynamics.from_params(kind, values)
    q = robot.neutral()
    offset = robot.potential_energy(q) - float(form.potential(fast.param_vector, *q))
    fast = FastDynamics(kind, fast.params, fast.damping, fast.nv, offset, robot.name)
    name, c = law_of(controller, fast)
    return controller, swing_need(controller.swing_up)[0], name, c, fast.param_vector


def need_of(kind: str, p: dict[str, float]) -> float:
    """The scale of the drawn effort, from the drawn parameters: the static part of
    :func:`robodyn.control.swing_up.swing_need` (the lift torque; NEED_CART_POLE of the weight). The
    need each run is judged against is swing_need's, which also weighs the swing's reaction."""
    if kind == "pendubot":
        return (p["m1"] * p["lc1"] + p["m2"] * p["l1"]) * G
    return NEED_CART_POLE * (p["m_cart"] + p["m"]) * G


def robot_params(robot: Any, kind: str) -> dict[str, float]:
    from robodyn.kinds import params

    return params.extract(robot, kind).as_dict()


def draw_family(label: str, n: int, seed: int, folder: Path, only: list[int] | None = None) -> dict[str, Any]:
    """``n`` systems of the family ``label``: their controllers, parameter vectors and two starts each.

    ``only`` keeps the systems of those indices (every system is still drawn, so system k is the
    same system as in the whole family's run).
    """
    kind, base = BASES[label]
    rng = np.random.default_rng(seed)
    drawn = []
    for _ in range(n):
        p = draw(base, kind, rng)
        ratio = float(np.exp(rng.uniform(np.log(EFFORT_RANGE[0]), np.log(EFFORT_RANGE[1]))))
        drawn.append((p, ratio))
    keep = list(range(n)) if only is None else only
    rows, cs, ps, controllers = [], [], [], []
    law = ""
    for k in keep:
        p, ratio = drawn[k]
        controller, need, law, c, pv = build(kind, p, ratio * need_of(kind, p), folder, k)
        cs.append(c)
        ps.append(pv)
        controllers.append(controller)
        rows.append({"system": k, "params": p, "effort": float(controller.lqr.plant.effort[0]), "need": need})
    plant = controllers[0].lqr.plant
    hanging = np.tile(plant.hanging(), (n, 1))
    random_q = hanging + np.column_stack([rng.uniform(-np.pi, np.pi, n) for _ in range(2)]) * plant.angular
    if kind == "cart_pole":
        random_q[:, 0] = rng.uniform(-1.0, 1.0, n)
    random_v = rng.normal(0.0, 1.0, (n, 2))
    starts = {"hanging": (hanging[keep], np.zeros((len(keep), 2))), "random": (random_q[keep], random_v[keep])}
    return {"kind": kind, "law": law, "rows": rows, "c": np.array(cs).T, "p": np.array(ps).T,
            "controllers": controllers, "starts": starts, "plant": plant}  # fmt: skip


def run_kind(
    labels: list[str], n: int, seed: int, duration: float, only: dict[str, list[int]] | None = None
) -> dict[str, Any]:
    """Every family of one kind and both starts in ONE vectorised rollout, then each run judged.

    Family ``label`` is drawn from ``seed + FAMILY_SEED[label]``; ``only`` maps a label to the
    indices of the systems to run (all when None).
    """
    with tempfile.TemporaryDirectory() as tmp:
        drawn = {}
        for i, label in enumerate(labels):
            (Path(tmp) / f"f{i}").mkdir()
            picked = None if only is None else only[label]
            drawn[label] = draw_family(label, n, seed + FAMILY_SEED[label], Path(tmp) / f"f{i}", picked)
    first = next(iter(drawn.values()))
    kind, law, plant = first["kind"], first["law"], first["plant"]
    blocks = [(label, start) for label in drawn for start in ("hanging", "random")]
    c = np.hstack([drawn[label]["c"] for label, _ in blocks])
    pv = np.hstack([drawn[label]["p"] for label, _ in blocks])
    q0 = np.vstack([drawn[label]["starts"][start][0] for label, start in blocks])
    v0 = np.vstack([drawn[label]["starts"][start][1] for label, start in blocks])
    r = rollout.closed_loop_family(
        kind, law, c, pv, np.zeros((2, c.shape[1])), q0, v0,
        duration=duration, dt=DT, upright=plant.upright(), angular=plant.angular, hold=outcome.HOLD,
    )  # fmt: skip
    out: dict[str, Any] = {}
    offset = 0
    for label, start in blocks:
        fam = drawn[label]
        size = len(fam["rows"])
        part = slice(offset, offset + size)
        offset += size
        entry = out.setdefault(label, {"kind": kind, "n": size, "duration_s": duration, "starts": {}})
        entry["starts"][start] = judge_family(kind, fam["controllers"], r, part, duration, fam["rows"])
    print(f"{kind}: {c.shape[1]} runs of {duration:g} s in {r.wall_time_s:.1f} s wall")
    return out


def judge_family(
    kind: str, controllers: list[Any], r: Any, part: slice, duration: float, rows: list[dict[str, Any]]
) -> dict[str, Any]:
    """Each run's outcome (the one decision), and the family's shares; ``part`` picks the family's runs in ``r``."""
    runs = []
    for i, controller in enumerate(controllers):
        k = range(r.q.shape[0])[part][i]
        effort = rows[i]["effort"]
        within_limits = kind != "pendubot" or (
            np.all(np.abs(r.q_min[k]) < ELBOW_LIMIT) and np.all(np.abs(r.q_max[k]) < ELBOW_LIMIT)
        )
        balanced = outcome.is_balanced(float(r.time_to_balance[k]), duration) and within_limits
        balanced = balanced and r.peak_torque[k] <= effort * (1 + 1e-9)
        reason = None
        if not balanced:
            qs = np.vstack([r.q_min[k], r.q_max[k], r.q[k]])
            vs = np.vstack([np.zeros(2), np.zeros(2), r.v[k]])
            reason = (
                outcome.diagnose(controller, qs, vs) if within_limits else "the elbow swept past its +-100 rad limits"
            )
            if not r.entered_region[k] and "effort" not in reason and "rail" not in reason:
                reason = "the hand-over never found the LQR's region of attraction"
        runs.append(
            {
                "system": rows[i]["system"],
                "balanced": bool(balanced),
                "time_to_balance_s": float(r.time_to_balance[k]) if balanced else None,
                "final_error_rad": float(r.final_error[k]),
                "peak_torque": float(r.peak_torque[k]),
                "effort": effort,
                "need": rows[i]["need"],
                "reason": reason,
            }
        )
    able = [x for x in runs if x["effort"] >= x["need"]]
    times = [x["time_to_balance_s"] for x in runs if x["balanced"]]
    peaks = [x["peak_torque"] / x["effort"] for x in runs]
    return {
        "runs": runs,
        "balanced": sum(x["balanced"] for x in runs) / len(runs),
        "able": len(able),
        "able_balanced": sum(x["balanced"] for x in able) / max(len(able), 1),
        "failed_with_reason": sum((not x["balanced"]) and x["reason"] is not None for x in runs) / len(runs),
        "failed_weak": sum((not x["balanced"]) and x["effort"] < x["need"] for x in runs) / len(runs),
        "time_median_s": float(np.median(times)) if times else None,
        "time_max_s": float(np.max(times)) if times else None,
        "peak_over_effort_max": float(np.max(peaks)),
        "wall_time_s": r.wall_time_s,
    }


def parse_only(text: str, n: int, parser: Any) -> dict[str, list[int]]:
    """``'LABEL:K,K'`` -> {LABEL: [K, K]}; a bad label or index is one line from ``parser`` (exit 2)."""
    label, _, indices = text.rpartition(":")
    if label not in BASES:
        parser.error(f"--only: unknown family {label!r}; expected one of {', '.join(map(repr, BASES))}")
    try:
        picked = [int(k) for k in indices.split(",")]
    except ValueError:
        parser.error(f"--only: expected LABEL:K[,K...] with integer indices, got {text!r}")
    bad = [k for k in picked if not 0 <= k < n]
    if bad:
        parser.error(f"--only: system {bad[0]} is not drawn with --n {n} (indices 0 to {n - 1})")
    return {label: picked}


def run_line(label: str, start: str, x: dict[str, Any]) -> str:
    """One run of ``--only``: its outcome, time, final error [rad], peak torque against its limit and need."""
    verdict = f"balanced at {x['time_to_balance_s']:.2f} s" if x["balanced"] else f"did not balance: {x['reason']}"
    return (
        f"{label} #{x['system']} from {start}: {verdict}; final error {x['final_error_rad']:.3g} rad, "
        f"peak torque {x['peak_torque']:.4g} of {x['effort']:.4g} (need {x['need']:.4g}) [N m | N]"
    )


def table(result: dict[str, Any]) -> str:
    """The Markdown table of the families."""
    lines = [
        "| family | start | runs | balanced | balanced where effort >= need | did not, with a reason "
        "| time to balance median / max [s] |",
        "|---|---|---|---|---|---|---|",
    ]
    for label, fam in result["families"].items():
        for start, s in fam["starts"].items():
            t = "-" if s["time_median_s"] is None else f"{s['time_median_s']:.1f} / {s['time_max_s']:.1f}"
            lines.append(
                f"| {label} | {start} | {fam['n']} | {s['balanced']:.0%} | {s['able_balanced']:.0%} of {s['able']} | "
                f"{s['failed_with_reason']:.0%} | {t} |"
            )
    return "\n".join(lines)


def chart(result: dict[str, Any], out: Path) -> None:
    """Time to balance against effort / need, one panel per family (crosses: did not balance)."""
    plt = pyplot()
    families = result["families"]
    fig, axes = plt.subplots(1, len(families), figsize=(4.5 * len(families), 3.6), squeeze=False)
    for ax, (label, fam) in zip(axes[0], families.items(), strict=True):
        for start, marker in (("hanging", "o"), ("random", "^")):
            runs = fam["starts"][start]["runs"]
            ratio = np.array([x["effort"] / x["need"] for x in runs])
            ok = np.array([x["balanced"] for x in runs])
            t = np.array([x["time_to_balance_s"] if x["balanced"] else np.nan for x in runs])
            ax.scatter(ratio[ok], t[ok], marker=marker, s=14, label=f"{start}: balanced")
            ax.scatter(ratio[~ok], np.full((~ok).sum(), fam["duration_s"]), marker="x", s=14, label=f"{start}: not")
        ax.axvline(1.0, color="grey", lw=0.8)
        ax.set_xscale("log")
        ax.set_xlabel("effort limit / need")
        ax.set_ylabel("time to balance [s]")
        ax.set_title(label, fontsize=9)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, out, "swing_up")


def main() -> None:
    parser = argument_parser(__doc__ or "")
    parser.add_argument("--n", type=int, default=100, help="systems per family (default 100)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--duration", type=float, default=DURATION, help="seconds per run (default 30)")
    parser.add_argument("--families", default=",".join(BASES), help="comma-separated family labels")
    parser.add_argument(
        "--only",
        help="run only these systems of a family, as drawn for --n, e.g. 'pendubot (Spong-Block):88,12' "
        "(prints each run; writes no JSON or chart)",
    )
    args = parser.parse_args()
    facts = run_facts()  # taken before the runs: its wall time is the whole benchmark's
    out = output_folder(args.out, overwrite_committed=args.overwrite_committed)
    labels = args.families.split(",")
    unknown = [label for label in labels if label not in BASES]
    if unknown:
        parser.error(f"--families: unknown family {unknown[0]!r}; expected one of {', '.join(map(repr, BASES))}")
    only = parse_only(args.only, args.n, parser) if args.only else None
    if only is not None:
        labels = list(only)
    families: dict[str, Any] = {}
    for kind in ("pendubot", "cart_pole"):
        mine = [label for label in labels if BASES[label][0] == kind]
        if mine:
            families.update(run_kind(mine, args.n, args.seed, args.duration, only))
    result = {"families": families, "dt_s": DT, "balance_tol_rad": outcome.BALANCE_TOL, "hold_s": outcome.HOLD}
    print(table(result))
    if only is not None:  # a look at chosen systems: their runs, not a family's figures
        for label, fam in families.items():
            for start, s in fam["starts"].items():
                for x in s["runs"]:
                    print(run_line(label, start, x))
        return
    chart(result, out)
    write_json(out, "swing_up", result, facts)


if __name__ == "__main__":
    main()
