"""``robodyn run scene.toml``: build the minimal model of a scene and run what it asks for.

Everything is checked before the work: the output folder, that no output is an input (the
scene, its URDF and SRDF) or another output, and how many frames [view] would render. A
simulation that stops early (diverged, Ctrl-C) writes ``NAME.partial.npz``, never over the
``NAME.npz`` of an earlier complete run, then the summary saying so.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from robodyn.cli._common import (
    add_passive_argument,
    add_physics_argument,
    file_path,
    strict_json,
    unchecked_scene,
    warn_unchecked,
)
from robodyn.cli._interrupts import held
from robodyn.cli._output import (
    check_output_file,
    check_output_folder,
    partial_path,
    refuse_clobbering,
    writable_path,
)
from robodyn.cli._summary import constraint_lines, note_clamped_q0
from robodyn.errors import EXIT_MISMATCH, EXIT_OK
from robodyn.fileio import write_text_atomically
from robodyn.wording import count


def add_parser(sub: Any) -> None:
    """Register ``robodyn run``."""
    p = sub.add_parser(
        "run",
        help="run a scene file: minimal model, check, simulate, bench, view",
        description="Read a scene file (TOML: [model], [initial], [control], [simulate], [check], [bench], "
        "[view], [output]), build the minimal model (joints not kept are locked), and run the parts the file "
        "asks for. Results go to [output] dir (default scene-out/<scene name>). Exit codes: 0 ok, 1 a check "
        "failed, 2 bad scene, 3 the simulation diverged, 130 interrupted (either way the trajectory so far is "
        "written first, as NAME.partial.npz).",
    )
    p.add_argument("scene", type=file_path, metavar="SCENE.toml", help="the scene file")
    p.add_argument("--out", type=file_path, default=None, help="output folder (overrides the scene's [output] dir)")
    p.add_argument("--no-view", action="store_true", help="skip the [view] part")
    add_physics_argument(p)
    add_passive_argument(p, what="the scene's model (added to its [model] passive)")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Run the scene; print one block per part; write the results."""
    from robodyn.scene import read_scene

    scene = unchecked_scene(read_scene(args.scene), args).with_passive(args.passive)
    if (scene.control or {}).get("kind") == "file":
        from robodyn.control.supervised import run_supervised

        # A controller file runs in a forked child: os._exit or a hang in it cannot fake a finished run.
        return run_supervised(lambda: _run_scene(args, scene), source=str(scene.control["path"]))
    return _run_scene(args, scene)


def _run_scene(args: argparse.Namespace, scene: Any) -> int:
    """Everything after reading the scene: model, check, simulation, closed form, bench, view."""
    from robodyn.errors import DivergenceError, SimulationInterrupted

    out = args.out or scene.output or Path("scene-out") / scene.name
    check_output_folder(out)  # before the model, the check and the exactness proof: a bad folder fails at once
    view = None if args.no_view else scene.view
    if view is not None and "html" in view:
        check_output_file(view["html"])
    outputs = _outputs(scene, out, view)
    refuse_clobbering(
        outputs, [("the scene", scene.path), *_model_files(scene.model.get("urdf"), scene.model.get("srdf"))]
    )
    if view is not None and scene.simulate is not None:
        from robodyn.cli.view import check_frame_count

        what = f"{scene.path}: [simulate] duration (played back by [view])"
        hint = "shorten [simulate] duration, or run with --no-view"
        check_frame_count(float(scene.simulate["duration"]), speed=1.0, fps=None, what=what, hint=hint)
    closed_form = _closed_form_module(scene)  # a bad file is refused before any work, not after the run
    robot, reduction = scene.build()
    if scene.model.get("physics_check") is False:
        warn_unchecked(robot, command="run")
    refuse_clobbering(outputs, _model_files(robot.urdf_path, robot.srdf_path))
    summary: dict[str, Any] = {"scene": str(scene.path), "model": robot.name, "nq": robot.nq, "nv": robot.nv}
    if reduction is not None:
        values = {k: v.tolist() for k, v in reduction.lock_values().items()}
        summary["full_nv"] = reduction.full.nv
        summary["kept"] = list(robot.joint_names)
        summary["locked"] = values
        print(f"model: {robot.name}, {reduction.full.nv} -> {robot.nv} DoF; kept {', '.join(robot.joint_names)}")
        print(f"  locked {count(len(values), 'joint')} at " + ", ".join(f"{k}={_short(v)}" for k, v in values.items()))
    else:
        print(f"model: {robot.name}, {robot.nv} DoF (nothing locked)")
    q0, v0 = scene.initial_state(robot, reduction)
    torque = scene.torque(robot, reduction)
    _check_system(scene, robot, torque)
    control = _control_record(scene)
    if control is not None:
        summary["control"] = control
        print(f"control: {_describe_control(control)}")
    status = EXIT_OK
    trajectory = None
    if scene.structural_check:
        status = max(status, _check(scene, robot, reduction, q0, v0, torque, summary))
    if scene.simulate is not None:
        try:
            trajectory = _simulate(scene, robot, reduction, q0, v0, torque, out, summary)
        except (DivergenceError, SimulationInterrupted):
            _write_summary(out, summary)  # the divergence is in it, next to the partial trajectory
            raise
        status = max(status, _judge(torque, trajectory, summary))
    if closed_form is not None:
        from robodyn.cli._closed_form import compare

        try:
            status = max(status, compare(scene, robot, trajectory, summary, closed_form))
        except DivergenceError:
            _write_summary(out, summary)  # the overflow is in it, next to the trajectory
            raise
    if scene.bench is not None:
        _bench(scene, robot, reduction, summary)
    playback = _view(view, _simulated_robot(scene, robot), trajectory, summary) if view is not None else None
    _write_summary(out, summary)
    if view is not None and playback is not None:  # last: the server runs until Ctrl-C
        from robodyn.cli.view import serve_playback

        served = serve_playback(playback, open_browser=bool(view.get("open")), zmq_url=None, port=view.get("port"))
        status = max(status, served)
    return status


def _closed_form_module(scene: Any) -> Any:
    """The scene's ``[check] closed_form`` module, imported and its functions checked; None without one."""
    if scene.check is None or "closed_form" not in scene.check:
        return None
    from robodyn.cli._closed_form import load, read_parameters

    path = Path(scene.check["closed_form"])
    module = load(scene, path)
    read_parameters(scene, path, module)  # the file's reading of the scene, before the run it is compared with
    return module


def _control_record(scene: Any) -> dict[str, Any] | None:
    """{kind, gains (and path)} of a scene's controller (lqr, swing_up, file), or None for another input."""
    from robodyn.scene.model import CONTROL_GAINS

    c = scene.control
    kind = c.get("kind")
    if kind not in CONTROL_GAINS:
        return None
    if kind == "file":
        return {"kind": kind, "path": str(c["path"]), "gains": dict(c.get("gains", {}))}
    return {"kind": kind, "gains": {k: c[k] for k in CONTROL_GAINS[kind] if k in c}}


def _describe_control(control: dict[str, Any]) -> str:
    """``swing_up (gains: Q=[10, 10, 1, 1], R=1)``, ``file ctl.py (default gains)``."""
    name = control["kind"] if control["kind"] != "file" else f"file {control['path']}"
    gains = control["gains"]
    if not gains:
        return f"{name} (default gains)"
    return f"{name} (gains: " + ", ".join(f"{k}={json.dumps(v)}" for k, v in gains.items()) + ")"


def _outputs(scene: Any, out: Path, view: dict[str, Any] | None) -> list[tuple[str, Path | None]]:
    """(label, path) of every file the scene may write."""
    html = view.get("html") if view is not None else None
    return [
        ("the summary", out / "summary.json"),
        ("the trajectory", out / f"{scene.name}.npz" if scene.simulate is not None else None),
        ("[view] html", html),
    ]


def _model_files(urdf: Path | None, srdf: Path | None) -> list[tuple[str, Path | None]]:
    return [("the model's URDF", urdf), ("the model's SRDF", srdf)]


def _write_summary(out: Path, summary: dict[str, Any]) -> None:
    path = writable_path(out / "summary.json")
    text = json.dumps(strict_json(summary), indent=2, default=_jsonable, allow_nan=False) + "\n"
    write_text_atomically(path, text)
    print(f"summary: {path}")


def _short(values: list[float]) -> str:
    return f"{values[0]:.4g}" if len(values) == 1 else "[" + " ".join(f"{x:.4g}" for x in values) + "]"


def _jsonable(obj: Any) -> Any:
    import numpy as np

    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)


def _check(scene: Any, robot: Any, reduction: Any, q0: Any, v0: Any, torque: Any, summary: dict[str, Any]) -> int:
    from robodyn.checker.compare import check
    from robodyn.checker.sandbox import DEFAULT_TIMEOUT as DEFAULT_FORMULA_TIMEOUT
    from robodyn.errors import FormulaError, UnknownNameError
    from robodyn.studies.exactness import prove_exact

    c = scene.check
    loops, springs = scene.constraints.loops, scene.constraints.springs
    try:
        report = check(
            robot,
            c.get("formula"),
            samples=int(c.get("samples", 20)),
            seed=int(c.get("seed", 0)),
            loops=loops,
            springs=springs,
            scene=scene.path,
            formula_timeout=float(c.get("formula_timeout", DEFAULT_FORMULA_TIMEOUT)),
        )
    except FormulaError as exc:  # the time limit is the scene's key here, not the check command's flag
        raise FormulaError(str(exc).replace("(--formula-timeout)", "([check] formula_timeout)")) from None
    except UnknownNameError as exc:  # a frame or joint of [constraints] or [springs], or the formula's INDEPENDENT
        where = ("check", "formula") if "INDEPENDENT" in exc.what else _constraint_key(exc)
        raise scene.error(*where, str(exc)) from None
    from robodyn.checker.rows import EQUATIONS_AGREE, FAIL

    failures = [row.quantity for row in report.failures]
    verdict = {FAIL: "FAILED", EQUATIONS_AGREE: "passed (equations of motion; C is not Christoffel's)"}
    print(
        f"check: {verdict.get(report.verdict, 'passed')} "
        f"({count(len(report.rows), 'row')}, {count(report.samples, 'sample')}"
        + (f", formula {report.formula}" if report.formula else "")
        + ")"
        + (f"; failed: {', '.join(failures)}" if failures else "")
    )
    for row in report.failures:  # the worst entry, then every other one out of tolerance (as check says them)
        others = [(m.entry, m.max_rel_error) for m in row.mismatches if m.entry != row.entry]
        for entry, rel in [(row.entry, row.max_rel_error), *others]:
            print(f"  MISMATCH {row.entry_label(entry)} ({row.quantity}): relative error {rel:.3g} > {row.tolerance:g}")
    summary["check"] = {
        "passed": report.passed,
        "verdict": report.verdict,
        "rows": len(report.rows),
        "failed": failures,
    }
    if report.kind == "constrained":  # the reduced Lagrangian: each term's worst relative error
        summary["check"]["worst_relative_error"] = {r.quantity: r.max_rel_error for r in report.rows}
    status = EXIT_MISMATCH if report.verdict == FAIL else EXIT_OK  # as robodyn check: a non-Christoffel C passes
    if c.get("exactness"):
        duration, dt, integrator = _timing(scene)
        if scene.constraints.limits:  # from the q0 the run starts at: moved inside the stops, as simulate moves it
            from robodyn.robot import as_vector
            from robodyn.sim.limits import stops_of

            q0 = stops_of(reduction.reduced).clamp(as_vector(q0, reduction.reduced.nq, "q0"))[0]
        exact = prove_exact(reduction, q0, v0, duration=duration, dt=dt, tau=torque, method=integrator)
        ok = exact.holds(EXACTNESS_TOL)
        held = count(len(reduction.locked), "joint")
        q_unit, v_unit, lock_unit = _exactness_units(reduction)
        print(
            f"exactness: {'passed' if ok else 'FAILED'}: reduced vs full model with {held} "
            f"held by constraint over {scene.simulate['duration']} s: max |dq| = {exact.q_error:.2e} {q_unit}, "
            f"max |dv| = {exact.v_error:.2e} {v_unit}, lock drift {exact.lock_drift:.2e} {lock_unit} "
            f"(tolerance {EXACTNESS_TOL:g} in each of these units)"
        )
        summary["exactness"] = {
            "passed": ok,
            "q_error": exact.q_error,
            "v_error": exact.v_error,
            "lock_drift": exact.lock_drift,
            "max_lock_torque": exact.max_lock_torque,
            "tolerance": EXACTNESS_TOL,
        }
        if not ok:
            status = EXIT_MISMATCH
    return status


# Reduced vs constrained full trajectory: the same integrator on two algorithms (ABA vs a
# KKT solve) differs by round-off that a few seconds of smooth motion grow to ~1e-12.
EXACTNESS_TOL = 1e-9


def _exactness_units(reduction: Any) -> tuple[str, str, str]:
    """The units of the kept q, the kept v and the locked q: ``rad``, ``m`` or ``rad | m`` where they mix."""
    import numpy as np

    from robodyn.sim.system import coordinate_units

    q_units, v_units = coordinate_units(reduction.full)
    locked_q = np.setdiff1d(np.arange(reduction.full.nq), reduction.kept_q)

    def one(units: list[str], mixed: str) -> str:
        found = sorted({u for u in units if u})
        return found[0] if len(found) == 1 else mixed

    return (
        one([q_units[i] for i in reduction.kept_q], "rad | m"),
        one([v_units[i] for i in reduction.kept_v], "rad/s | m/s"),
        one([q_units[i] for i in locked_q], "rad | m"),
    )


def _timing(scene: Any) -> tuple[float, float, str]:
    """The scene's [simulate] duration [s], dt [s] and integrator name."""
    sim = scene.simulate
    return float(sim["duration"]), float(sim["dt"]), str(sim["integrator"])


def _simulate(
    scene: Any, robot: Any, reduction: Any, q0: Any, v0: Any, torque: Any, out: Path, summary: dict[str, Any]
) -> Any:
    import dataclasses

    from robodyn.errors import DivergenceError, InputError, SimulationInterrupted, UnknownNameError
    from robodyn.sim.simulation import simulate

    duration, dt, integrator = _timing(scene)
    path = out / f"{scene.name}.npz"
    try:
        trajectory = simulate(
            robot,
            q0,
            v0,
            duration=duration,
            dt=dt,
            integrator=integrator,
            torque=torque,
            backend=scene.simulate.get("backend"),  # None: simulate picks (crba with mimic joints)
            constraints=scene.constraints,
        )
    except (DivergenceError, SimulationInterrupted) as exc:
        raise _stopped_early(exc, path, summary) from None
    except (InputError, UnknownNameError, RuntimeError) as exc:
        raise _system_error(scene, exc) from None
    abandoned = f"interrupted twice while the finished run was being written; {path} not written"
    with held(abandoned=lambda: abandoned) as ctrl_c:  # the run is over: a Ctrl-C must not lose it
        if reduction is not None:
            meta = dict(trajectory.meta)
            meta["reduction"] = {
                "full_nv": reduction.full.nv,
                "locked": {k: v.tolist() for k, v in reduction.lock_values().items()},
            }
            trajectory = dataclasses.replace(trajectory, meta=meta)
        trajectory.save(writable_path(path))
        note_clamped_q0(trajectory, command="run")
    print(
        f"simulate: {count(trajectory.n_steps, 'step')} of {scene.simulate['dt']} s with {integrator} in "
        f"{trajectory.wall_time_s:.3f} s wall; energy ledger residual {abs(trajectory.ledger_residual).max():.2e} J; "
        f"written to {path}"
    )
    print(f"  power: average {trajectory.average_power:.6g} W (W_input {float(trajectory.work_input[-1]):.6g} J)")
    for line in constraint_lines(trajectory, robot.model.effortLimit):
        print(f"  {line}")
    s = trajectory.summary()
    summary["simulate"] = {
        "steps": trajectory.n_steps,
        "wall_time_s": trajectory.wall_time_s,
        "ledger_residual": float(abs(trajectory.ledger_residual).max()),
        "trajectory": str(path),
        **{key: s[key] for key in CONSTRAINT_FIGURES},
    }
    if ctrl_c:  # written whole: the one line says where, and the scene's later parts are not run
        summary["simulate"]["interrupted"] = True
        raise SimulationInterrupted(
            f"interrupted after the simulation had finished; its trajectory is written to {path}", trajectory=trajectory
        )
    return trajectory


# The figures of a run's constraints that go to summary.json (as Trajectory.summary() names them).
CONSTRAINT_FIGURES = (
    "work_limits",
    "average_power",
    "effort_clamped_samples",
    "impacts",
    "limit_violation",
    "loop_drift",
)


def _judge(torque: Any, trajectory: Any, summary: dict[str, Any]) -> int:
    """A swing-up scene's outcome (:mod:`robodyn.control.outcome`, as simulate's): printed, in the summary, its exit."""
    from robodyn.cli import _control
    from robodyn.errors import EXIT_NOT_BALANCED

    verdict = _control.outcome(torque, trajectory)
    if verdict is None:
        return EXIT_OK
    summary["simulate"]["outcome"] = verdict.as_record()
    print(f"  {verdict.line()}")
    if verdict.balanced:
        return EXIT_OK
    print(f"robodyn run: the controller did not reach its goal: {verdict.reason}", file=sys.stderr)
    return EXIT_NOT_BALANCED


def _constraint_key(exc: Any) -> tuple[str, str]:
    """([table], key) of an unknown name: ``frame (loops[0].frame_a)`` -> constraints, loops[0].frame_a."""
    inside = str(exc.what).partition("(")[2].rstrip(")")
    return ("springs", str(exc.name)) if inside == "springs" else ("constraints", inside or "loops")


def _stopped_early(exc: BaseException, path: Path, summary: dict[str, Any]) -> BaseException:
    """Write the partial trajectory as ``NAME.partial.npz``, note it in ``summary``; return the error to raise.

    The error's one line then says where the partial run went, and that ``path`` (an
    earlier complete run) is left as it was.
    """
    from robodyn.errors import DivergenceError, SimulationInterrupted

    trajectory = getattr(exc, "trajectory", None)
    diverged = isinstance(exc, DivergenceError)
    record: dict[str, Any] = {"diverged": diverged, "interrupted": not diverged, "message": str(exc)}
    if isinstance(exc, DivergenceError):
        record.update(step=exc.step, time=exc.time)
    summary["simulate"] = record
    message = str(exc)
    if trajectory is not None:
        partial = writable_path(partial_path(path))
        with held(abandoned=lambda: f"interrupted twice while {partial} was being written; not written"):
            trajectory.save(partial)
        record["trajectory"] = str(partial)
        kept = f" ({path} left as it was)" if path.exists() else ""
        message += f"; partial trajectory written to {partial}{kept}"
        print(f"simulate: {'diverged' if diverged else 'interrupted'}; partial trajectory written to {partial}")
    if isinstance(exc, DivergenceError):
        return DivergenceError(message, step=exc.step, time=exc.time, trajectory=trajectory)
    return SimulationInterrupted(message, trajectory=trajectory)


def _system_error(scene: Any, exc: Exception) -> Exception:
    """The one-line error for what assembling the scene's system refused: its constraints, its backend, its model."""
    from robodyn.errors import InputError, ModelError, UnknownNameError

    if isinstance(exc, UnknownNameError):  # a frame or joint of [constraints] or [springs]
        return scene.error(*_constraint_key(exc), str(exc))
    if isinstance(exc, InputError):
        if str(exc).startswith(("loops[", "couplings[")):  # frames that cannot meet, a joint already coupled
            return scene.error("constraints", str(exc).split(" ")[0].split(":")[0], str(exc))
        return exc
    from robodyn.model.load import pinocchio_message  # RuntimeError: Pinocchio refusing the model (ABA and mimic)

    hint = ' (mimic joints: try [simulate] backend = "crba")' if scene.model.get("mimic") else ""
    return ModelError(f"simulate: Pinocchio refused the model: {pinocchio_message(exc)}{hint}")


def _check_system(scene: Any, robot: Any, torque: Any) -> None:
    """Assemble what [simulate] would integrate (constraints, springs, backend, torque) and drop it.

    Every section is checked against the model before any work, whether or not the scene simulates.
    """
    from robodyn.errors import InputError, UnknownNameError
    from robodyn.sim.system import robot_system

    backend = scene.simulate.get("backend") if scene.simulate is not None else None
    try:
        robot_system(robot, backend=backend, torque=torque, constraints=scene.constraints)
    except (InputError, UnknownNameError, RuntimeError) as exc:
        raise _system_error(scene, exc) from None


def _simulated_robot(scene: Any, robot: Any) -> Any:
    """The robot whose coordinates the trajectory holds: with couplings, the coupled one (followers as mimic joints)."""
    if not scene.constraints.couplings:
        return robot
    from robodyn.sim.couplings import couple

    coupled = couple(robot, scene.constraints.couplings)
    return robot if coupled is None else coupled.coupled


def _bench(scene: Any, robot: Any, reduction: Any, summary: dict[str, Any]) -> None:
    from robodyn.studies.exactness import compare_cost, time_calls
    from robodyn.studies.report import speed_phrase

    repeat = int(scene.bench.get("repeat", 200))
    if reduction is None:
        times = time_calls(robot, repeat=repeat)
        print("bench: per call " + ", ".join(f"{k} {v * 1e6:.2f} us" for k, v in times.items()))
        summary["bench"] = {"per_call_s": times}
        return
    cost = compare_cost(reduction, repeat=repeat)
    print(f"bench: per call, full model ({cost.nv_full} DoF) -> minimal model ({cost.nv_reduced} DoF):")
    for what in cost.full:
        print(
            f"  {what:4s} {cost.full[what] * 1e6:8.2f} us -> {cost.reduced[what] * 1e6:8.2f} us  "
            f"({speed_phrase(cost.speedup(what))})"
        )
    summary["bench"] = {"full_per_call_s": cost.full, "reduced_per_call_s": cost.reduced, "repeat": repeat}


def _view(view: dict[str, Any], robot: Any, trajectory: Any, summary: dict[str, Any]) -> Any:
    """Write the [view] html file, or return the playback to serve once everything else is written."""
    from robodyn import viewer
    from robodyn.cli.view import write_html

    playback = viewer.build(robot, trajectory)
    if "html" in view:
        path = write_html(playback, view["html"], open_browser=bool(view.get("open")))
        summary["view"] = {"html": str(path)}
        return None
    summary["view"] = {"server_port": view.get("port")}
    return playback
