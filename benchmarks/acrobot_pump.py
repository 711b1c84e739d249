"""How fast a pump through the elbow starts an Acrobot's swing from hanging: why the Acrobot law starts with a kick.

An Acrobot is the Pendubot's two links with the shoulder passive and the elbow driven. From hanging
at rest a swing-up law must first make the hanging rest unstable, and how fast the swing grows from
a small disturbance is the closed loop's largest growth rate there. This script linearises two
published laws about the hanging rest, on the model's own M and h (Pinocchio, through
:mod:`robodyn.dynamics`), for drawn Acrobots, and reports the best growth rate a scan of their
gains reaches, in units of the arm's pendulum frequency w = sqrt(|G_1| / M_11) with both links
horizontal and straight:

* **Spong's pump** (M. W. Spong, "The swing up control problem for the Acrobot", IEEE Control
  Systems 15(1), 1995): collocated PFL on the elbow, q2'' = k_p (gamma q1' / w - q2) - k_d q2'
  (his arctan reference gamma' arctan(q1') linearised);
* **Xin and Kaneda's energy law** (X. Xin and M. Kaneda, "Analysis of the energy-based swing-up
  control of the Acrobot", Int. J. Robust Nonlinear Control 17(16), 2007): the torque that makes
  V = k_E/2 (E - E_up)^2 + k_D/2 q2'^2 + k_P/2 q2^2 fall at -k_V q2'^2.

Growth is split into the oscillating mode (a swing that grows) and a real one (link 1 leaning off to
one side while the elbow folds: no swing). Run: ``python benchmarks/acrobot_pump.py --out DIR``;
saves ``acrobot_pump.json``.
"""

from __future__ import annotations

import itertools
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

import robodyn
from robodyn import dynamics

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_swing_up import BASES, PENDUBOT, draw

from _common import argument_parser, output_folder, run_facts, write_json

FAMILIES = ("pendubot (built-in)", "pendubot (Spong-Block)")
SPONG_GAINS = list(itertools.product((2.0, 4.0, 10.0, 25.0), (1.0, 2.0, 4.0, 7.0), (1.0, 3.0, 10.0, -1.0, -3.0)))
XK_GAINS = list(itertools.product((2.05, 2.5, 3.0), (0.3, 1.0, 3.0), (0.3, 1.0, 3.0)))
HANGING = np.array([-np.pi / 2, 0.0, 0.0, 0.0])


def acrobot(p: dict[str, float], folder: Path, k: int) -> Any:
    """The drawn two-link arm ``p`` with its shoulder passive (effort unlimited on the elbow)."""
    text = PENDUBOT.format(effort="0", **{n: repr(v) for n, v in p.items()}).replace(
        'effort="0" velocity="100"/></joint></robot>', 'effort="1000" velocity="100"/></joint></robot>'
    )
    path = folder / f"acrobot_{k}.urdf"
    path.write_text(text)
    return robodyn.load(path, passive=["joint1"])


def scales(robot: Any) -> tuple[float, float, float, float]:
    """(w [rad/s], |G_1| straight and horizontal [N m], E_up [J], max over q2 of the elbow's Mbar [kg m^2])."""
    model, data = robot.model, robot.data
    flat = np.array([0.0, 0.0])
    weight = abs(float(dynamics.gravity(model, data, flat)[0]))
    omega = float(np.sqrt(weight / dynamics.mass_matrix(model, data, flat)[0, 0]))
    e_up = dynamics.potential_energy(model, data, np.array([np.pi / 2, 0.0]))
    mbar = 0.0
    for q2 in np.linspace(-np.pi, np.pi, 73):
        M = dynamics.mass_matrix(model, data, np.array([0.0, q2]))
        mbar = max(mbar, float(M[1, 1] - M[0, 1] ** 2 / M[0, 0]))
    return omega, weight, e_up, mbar


def rates(robot: Any, law: str, gains: tuple[float, float, float], sc: tuple[float, float, float, float]) -> Any:
    omega, weight, e_up, mbar = sc
    model, data = robot.model, robot.data

    def f(x: np.ndarray) -> np.ndarray:
        q, v = x[:2], x[2:]
        M = dynamics.mass_matrix(model, data, q)
        h = dynamics.nonlinear_effects(model, data, q, v)
        det = M[0, 0] * M[1, 1] - M[0, 1] ** 2
        if law == "spong":
            k_p, k_d, gamma = gains[0] * omega**2, gains[1] * omega, gains[2]
            w = k_p * (gamma * v[0] / omega - q[1]) - k_d * v[1]
            return np.array([v[0], v[1], -(M[0, 1] * w + h[0]) / M[0, 0], w])
        k_e, k_d, k_p, k_v = 1.0 / weight, gains[0] * mbar, gains[1] * weight, gains[2] * weight / omega
        energy = 0.5 * v @ M @ v + dynamics.potential_energy(model, data, q) - e_up
        u = -(k_d * (M[0, 1] * h[0] - M[0, 0] * h[1]) / det + k_p * q[1] + k_v * v[1]) / (
            k_e * energy + k_d * M[0, 0] / det
        )
        a = np.linalg.solve(M, np.array([0.0, u]) - h)
        return np.array([v[0], v[1], a[0], a[1]])

    return f


def growth(f: Any, omega: float) -> tuple[float, float]:
    """(oscillating, real) largest growth rates of the linearisation at hanging, in units of ``omega``."""
    jac = np.zeros((4, 4))
    for j in range(4):
        step = np.zeros(4)
        step[j] = 1e-6
        jac[:, j] = (f(HANGING + step) - f(HANGING - step)) / 2e-6
    lam = np.linalg.eigvals(jac) / omega
    swing = lam[np.abs(lam.imag) > 1e-9]
    lean = lam[np.abs(lam.imag) <= 1e-9]
    return (float(np.max(swing.real)) if swing.size else -np.inf, float(np.max(lean.real)) if lean.size else -np.inf)


def family(label: str, n: int, seed: int, folder: Path) -> dict[str, Any]:
    rng = np.random.default_rng(seed)
    _, base = BASES[label]
    rows = []
    for k in range(n):
        p = dict(base) if k == 0 else draw(base, "pendubot", rng)
        robot = acrobot(p, folder, k)
        sc = scales(robot)
        row: dict[str, Any] = {"system": k, "omega_rad_s": sc[0]}
        for law, scan in (("spong", SPONG_GAINS), ("xin_kaneda", XK_GAINS)):
            best = max((growth(rates(robot, law, g, sc), sc[0]), g) for g in scan if law != "spong" or g[2] > 0)
            row[law] = {"swing_growth_per_omega": best[0][0], "gains": list(best[1])}
        lean = max(growth(rates(robot, "spong", g, sc), sc[0])[1] for g in SPONG_GAINS if g[2] < 0)
        row["spong_reversed_lean_growth_per_omega"] = lean
        rows.append(row)
        best = row["spong"]["swing_growth_per_omega"], row["xin_kaneda"]["swing_growth_per_omega"]
        print(
            f"{label} #{k}: w {sc[0]:.3g} rad/s, best swing growth / w: Spong {best[0]:.3f}, Xin-Kaneda {best[1]:.3f}"
        )
    return {"label": label, "seed": seed, "systems": rows, **summary(rows)}


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for law in ("spong", "xin_kaneda"):
        g = np.array([r[law]["swing_growth_per_omega"] for r in rows])
        seconds = np.log(100.0) / np.maximum(g * np.array([r["omega_rad_s"] for r in rows]), 1e-12)
        out[law] = {
            "swing_growth_per_omega": {"median": float(np.median(g)), "max": float(np.max(g))},
            "seconds_0.01_to_1_rad": {"median": float(np.median(seconds)), "min": float(np.min(seconds))},
        }
    return out


def main() -> None:
    parser = argument_parser(__doc__ or "")
    parser.add_argument("--n", type=int, default=20, help="systems per family (the first is the family's base)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the draws")
    args = parser.parse_args()
    out = output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()
    with tempfile.TemporaryDirectory() as tmp:
        result = {"families": [family(label, args.n, args.seed + i, Path(tmp)) for i, label in enumerate(FAMILIES)]}
    path = write_json(out, "acrobot_pump", result, facts)
    for fam in result["families"]:
        for law in ("spong", "xin_kaneda"):
            s = fam[law]
            g, sec = s["swing_growth_per_omega"], s["seconds_0.01_to_1_rad"]
            print(
                f"{fam['label']}, {law}: best swing growth {g['median']:.3f} w (median), {g['max']:.3f} w (max); "
                f"from 0.01 to 1 rad in {sec['median']:.3g} s (median), {sec['min']:.3g} s (fastest)"
            )
    print(f"saved {path}")


if __name__ == "__main__":
    main()
