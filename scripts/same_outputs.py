"""Save the outputs of representative runs, or compare two saved sets array by array (a refactor's check).

    python scripts/same_outputs.py save OUT            # CLI runs (--out .npz) and API runs, CPU paths
    NUMBA_ENABLE_CUDASIM=1 python scripts/same_outputs.py save OUT --cuda   # the GPU paths, in numba's simulator
    python scripts/same_outputs.py compare BEFORE AFTER

Run ``save`` on the commit before a refactor and on the one after (each with its own
``NUMBA_CACHE_DIR``), then ``compare``: every array must be bit-identical (np.array_equal); a
trajectory's ``metadata`` is compared without its wall times and file paths. The engine move of
issue 40 compared 186 arrays in 30 files this way.
"""

import json
import sys
from pathlib import Path

import numpy as np


def save_all(out: Path, cuda: bool, api_only: bool) -> None:
    """Every run's arrays into ``out`` as .npz: the CPU paths, or with ``cuda`` the GPU paths."""
    import robodyn
    from robodyn.cli import main

    def save(name, **arrays):
        np.savez(out / f"{name}.npz", **{k: np.asarray(v) for k, v in arrays.items()})

    if not cuda and not api_only:
        runs = {
            "pendubot_rk4": "simulate pendubot --q0 0.3,-0.2 --duration 2 --dt 1e-3",
            "pendubot_euler": "simulate pendubot --q0 0.5,0 --duration 2 --dt 0.01 --integrator euler "
            "--max-energy-growth 100",
            "cart_rail": "simulate cart_pole --q0 0,0.2 --torque 5 --duration 3 --restitution 0.5",
            "geared": "simulate geared_arm --q0 0.4 --duration 2",
            "pendubot_lqr": "simulate pendubot --q0 1.6,0.05 --controller lqr --duration 2",
            "cart_swing": "simulate cart_pole --q0 0,3.14159 --controller swing_up --duration 3",
            "panda_stops": "simulate panda --duration 1 --v0 3,-3,3,-3,3,-3,3,0,0",
            "pendubot_fast_backend": "simulate pendubot --q0 0.3,-0.2 --duration 1 --backend formula",
        }
        for name, argv in runs.items():
            path = out / f"cli_{name}.npz"
            rc = main([*argv.split(), "--out", str(path)])
            print(name, rc, flush=True)
    if not cuda:
        from robodyn.sim import batch
        from robodyn.sim.fast import FastDynamics

        for kind, q0 in (("pendubot", [0.3, -0.2]), ("cart_pole", [0.1, 0.2]), ("geared_arm", [0.4])):
            robot = robodyn.load(kind)
            fast = FastDynamics.from_robot(robot)
            for method in ("rk4", "semi_implicit_euler"):
                tr = fast.simulate(
                    q0, np.zeros(len(q0)), duration=1.0, dt=1e-3, method=method, tau=np.full(len(q0), 0.3)
                )
                save(
                    f"fast_{kind}_{method}",
                    q=tr.q,
                    v=tr.v,
                    a=tr.a,
                    K=tr.kinetic,
                    P=tr.potential,
                    wi=tr.work_input,
                    wd=tr.work_damping,
                )
            rng = np.random.default_rng(3)
            Q = rng.uniform(-2, 2, (20, robot.nv))
            V = rng.uniform(-1, 1, (20, robot.nv))
            r = batch.rollout(robot, Q, V, duration=0.5, dt=1e-3, threads=2)
            save(f"batch_{kind}", q=r.q, v=r.v)
            from robodyn import control
            from robodyn.control import rollout

            if kind != "geared_arm":
                ctl = control.make("lqr", robot)
                rr = rollout.closed_loop(
                    robot,
                    ctl.batch,
                    Q * 0.05 + np.array([np.pi, 0][: robot.nv]) * (kind == "pendubot"),
                    V * 0.05,
                    duration=0.5,
                    dt=1e-3,
                )
                save(f"closed_loop_{kind}", q=rr.q, v=rr.v, qmin=rr.q_min, qmax=rr.q_max)
        robot = robodyn.load("ur5")
        rng = np.random.default_rng(4)
        Q = rng.uniform(-2, 2, (6, robot.nv))
        V = rng.uniform(-1, 1, (6, robot.nv))
        for integ in ("rk4", "heun"):
            r = batch.rollout(robot, Q, V, duration=0.1, dt=1e-3, threads=2, integrator=integ)
            save(f"batch_ur5_{integ}", q=r.q, v=r.v)
    else:
        from robodyn import control
        from robodyn.control import rollout
        from robodyn.sim import batch

        for kind in ("pendubot", "cart_pole", "geared_arm"):
            robot = robodyn.load(kind)
            rng = np.random.default_rng(11)
            Q = rng.uniform(-3.0, 3.0, (6, robot.nv))
            V = rng.uniform(-2.0, 2.0, (6, robot.nv))
            g = batch.rollout(robot, Q, V, duration=0.05, dt=1e-3, device="cuda")
            save(f"cuda_batch_{kind}", q=g.q, v=g.v)
            g = batch.rollout(robot, Q, V, duration=0.05, dt=1e-3, device="cuda", dtype=np.float32)
            save(f"cuda_batch32_{kind}", q=g.q, v=g.v)
            if kind != "geared_arm":
                ctl = control.make("swing_up", robot)
                rr = rollout.closed_loop(robot, ctl, Q * 0.05, V * 0.05, duration=0.05, dt=1e-3, backend="cuda")
                save(f"cuda_closed_{kind}", q=rr.q, v=rr.v, qmin=rr.q_min, qmax=rr.q_max)
        robot = robodyn.load("ur5")
        rng = np.random.default_rng(4)
        Q = rng.uniform(-2, 2, (3, robot.nv))
        V = rng.uniform(-1, 1, (3, robot.nv))
        g = batch.rollout(robot, Q, V, duration=0.01, dt=1e-3, device="cuda")
        save("cuda_tree_ur5", q=g.q, v=g.v)


def clean(meta):
    """A trajectory's metadata without what changes from run to run: wall times, file paths."""
    if isinstance(meta, dict):
        return {
            k: clean(v)
            for k, v in meta.items()
            if k not in ("wall_time_s", "urdf", "srdf") and not k.endswith("wall_time_s")
        }
    return meta


def compare(a: Path, b: Path) -> int:
    """Print how many arrays of ``a``'s files are identical in ``b``'s; 0 when all are."""
    n = same = 0
    bad, missing = [], []
    files = sorted(p.name for p in a.glob("*.npz"))
    for name in files:
        if not (b / name).is_file():
            missing.append(name)
            continue
        x, y = np.load(a / name, allow_pickle=True), np.load(b / name, allow_pickle=True)
        for key in x.files:
            n += 1
            if key == "metadata":
                ok = clean(json.loads(str(x[key]))) == clean(json.loads(str(y[key])))
            else:
                ok = (
                    key in y.files
                    and x[key].dtype == y[key].dtype
                    and np.array_equal(x[key], y[key], equal_nan=x[key].dtype.kind in "fc")
                )
            same += ok
            if not ok:
                bad.append(f"{name}:{key}")
    print(f"{len(files)} files, {n} arrays, {same} identical; differing: {bad}; missing: {missing}")
    return 1 if bad or missing else 0


if __name__ == "__main__":
    if len(sys.argv) >= 3 and sys.argv[1] == "save":
        target = Path(sys.argv[2])
        target.mkdir(parents=True, exist_ok=True)
        save_all(target, "--cuda" in sys.argv, "--api" in sys.argv)
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        sys.exit(compare(Path(sys.argv[2]), Path(sys.argv[3])))
    else:
        sys.exit(__doc__)
