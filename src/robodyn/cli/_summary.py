"""What ``robodyn simulate`` (and ``robodyn run``) print about a finished run: the summary lines.

The state with its units, the energy line (drift from E0 when no work was exchanged, else the
change the works account for), the ledger, the constraints' lines (efforts, stops, loops), the
clamped-q0 note and the JSON summary. Only printing: the run is over when these are called.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

from robodyn.cli import _control
from robodyn.cli._common import print_json
from robodyn.wording import count


def _vec(x: Any, units: list[str] | None) -> str:
    """``[0.1 m, 6.151342 rad]``: each entry with its unit (none for a cos/sin pair or a quaternion)."""
    values = np.asarray(x, dtype=np.float64).reshape(-1)
    if units is None or len(units) != values.size:
        units = [""] * values.size
    return "[" + ", ".join(f"{v:.7g} {u}" if u else f"{v:.7g}" for v, u in zip(values, units, strict=True)) + "]"


def constraint_lines(trajectory: Any, effort: Any = None) -> list[str]:
    """What the constraints did, one line each: clamped torques, impacts, the worst violation and loop drift.

    ``effort`` (nv,) [N m | N], the model's effort limits, lets the first line say when the
    commanded torque itself sat at a limit: a controller that saturates its own command.
    """
    s, meta = trajectory.summary(), trajectory.meta
    samples = len(trajectory.t)
    clamped = int(s["effort_clamped_samples"] or 0)
    efforts = "on" if (meta.get("constraints") or {}).get("effort_limits", True) else "off"
    of_samples = count(samples, "sample", thousands=True)
    if clamped:
        lines = [f"efforts: tau clamped at the effort limit in {clamped:,} of {of_samples}"]
    else:
        at_limit = _samples_at_limit(trajectory.tau, effort)
        line = f"efforts: robodyn never clamped tau (effort limits {efforts}; {of_samples})"
        saturated = "the commanded tau itself was at its effort limit"
        if at_limit:
            line += f"; {saturated} in {at_limit:,} of them (saturated at its source)"
        lines = [line]
    limits = (meta.get("constraints") or {}).get("limits", True)
    if not limits:
        lines.append("stops: off (--no-limits): the joints pass through their limits")
    else:
        impacts = int(s["impacts"] or 0)
        joint = meta.get("limit_violation_joint")
        where = f" ({joint}, {_unit_of(meta, joint)})" if joint else " [rad | m]"
        violation = float(s["limit_violation"] or 0.0)
        restitution = (meta.get("constraints") or {}).get("restitution", 0.0)
        lines.append(
            f"stops: {count(impacts, 'impact', thousands=True)} (restitution {restitution:g}), "
            f"W_limits = {s['work_limits']:.6g} J, worst limit violation {violation:.3e}{where}"
        )
    if s["loop_drift"] is not None:
        lines.append(f"loops: worst drift max|residual| = {float(s['loop_drift']):.3e} m")
    return lines


def clamped_q0_line(meta: dict[str, Any]) -> str | None:
    """One line saying which joints of q0 were moved onto their limits (given value, limit, unit), or None."""
    moved = meta.get("q0_clamped") or {}
    if not moved:
        return None
    parts = []
    for joint, (given, inside) in moved.items():
        unit = _unit_of(meta, joint)
        side = "upper" if given > inside else "lower"
        parts.append(
            f"{joint} = {given:.7g} {unit} is outside its limits, moved onto its {side} limit {inside:.7g} {unit}"
        )
    return "q0: " + "; ".join(parts) + " (the run starts there)"


def note_clamped_q0(trajectory: Any, *, command: str) -> None:
    """The :func:`clamped_q0_line` as a ``note:`` on stderr, when q0 was moved onto a joint's limits."""
    line = clamped_q0_line(trajectory.meta)
    if line is not None:
        print(f"robodyn {command}: note: {line}", file=sys.stderr)


def _unit_of(meta: dict[str, Any], joint: str) -> str:
    """The unit of ``joint``'s coordinate (``rad`` or ``m``) from the metadata, ``rad | m`` if unknown."""
    names, units = meta.get("joint_names") or [], meta.get("q_units") or []
    if joint in names and len(names) == len(units):
        return str(units[names.index(joint)]) or "rad | m"
    return "rad | m"


def _loop_phrase(meta: dict[str, Any]) -> str:
    """'compiled loop', or 'Python loop: <why the compiled loop was not used>' (from the run's metadata)."""
    if meta.get("loop") == "compiled":
        events = int(meta.get("event_steps") or 0)
        # the ABA's passes named where they are not the usual world axes (robodyn.sim.tree.compiled_of)
        local = ", ABA in each joint's axes" if meta.get("aba_passes") == "joint axes" else ""
        return f"compiled loop{local}, {count(events, 'step')} with stop events" if events else f"compiled loop{local}"
    why = str(meta.get("compiled_loop") or "").removeprefix("not used: ")
    return f"Python loop: {why}" if why else "Python loop"


def _samples_at_limit(tau: Any, effort: Any) -> int:
    """Samples where some joint's |tau| reached its (positive, finite) effort limit, to 1e-9 relative."""
    if effort is None:
        return 0
    tau = np.asarray(tau, dtype=np.float64)
    limit = np.asarray(effort, dtype=np.float64).reshape(-1)
    if tau.ndim != 2 or tau.shape[1] != limit.size:
        return 0
    bounded = np.isfinite(limit) & (limit > 0)
    hit = np.abs(tau[:, bounded]) >= limit[bounded] * (1 - 1e-9)
    return int(np.count_nonzero(hit.any(axis=1)))


def energy_line(s: dict[str, Any]) -> str:
    """The energy line: drift from E0 when no work is exchanged, else the change the works account for."""
    head = f"energy: E0 = {s['energy_initial']:.9g} J, E(t) = {s['energy_final']:.9g} J, "
    worked = any(abs(float(s[k] or 0.0)) > 0.0 for k in ("work_input", "work_damping", "work_limits"))
    if not worked:
        return head + f"drift max|E - E0| = {s['energy_drift']:.3e} J (relative {s['relative_energy_drift']:.3e})"
    change = float(s["energy_final"]) - float(s["energy_initial"])
    return head + (
        f"change E(t) - E0 = {change:.6g} J: work was exchanged, so the drift from E0 is no error measure here; "
        "the ledger's residual below is"
    )


def _report(
    trajectory: Any,
    out: Path | None,
    csv: Path | None,
    *,
    as_json: bool,
    effort: Any = None,
    outcome: dict[str, Any] | None = None,
) -> None:
    """The run's summary, as text or JSON; ``outcome`` (a swing-up's verdict as a record) joins the JSON."""
    s = trajectory.summary()
    if out is not None:
        s["out"] = str(out)
    if csv is not None:
        s["csv"] = str(csv)
    meta = trajectory.meta
    controller = meta.get("controller")
    if controller is not None:
        s["controller"] = controller
    s["backend"] = meta.get("backend")
    s["loop"] = meta.get("loop")
    s["compiled_loop"] = meta.get("compiled_loop")
    s["event_steps"] = meta.get("event_steps")  # steps of the event stepper inside a compiled run; None: Python loop
    if meta.get("stiff_friction"):
        s["stiff_friction"] = meta["stiff_friction"]
    if meta.get("chattering"):
        s["chattering"] = meta["chattering"]
    if outcome is not None:
        s["outcome"] = outcome
    if as_json:
        print_json(s)
        return
    print(
        f"{s['model']}: {s['integrator']} (order {meta.get('order')}), dt = {s['dt']:g} s, "
        f"{count(s['steps'], 'step')} to t = {s['t_final']:g} s in {s['wall_time_s']:.3f} s wall "
        f"({count(s['evaluations'], 'dynamics evaluation')}, backend {meta.get('backend')}, {_loop_phrase(meta)})"
    )
    if controller is not None:
        print(f"controller: {_control.describe(controller['name'], controller['gains'])}")
    print(f"final state: q = {_vec(s['q_final'], s['q_units'])}, v = {_vec(s['v_final'], s['v_units'])}")
    print(energy_line(s))
    print(
        f"ledger: W_input = {s['work_input']:.9g} J, W_damping = {s['work_damping']:.9g} J, "
        f"W_limits = {s['work_limits']:.9g} J, "
        f"residual max|E - E0 - W_input - W_damping - W_limits| = {s['max_ledger_residual']:.3e} J"
    )
    if meta.get("stiff_friction"):  # one line, however many joints
        from robodyn.sim.stiffness import warning_line

        print(warning_line(meta["stiff_friction"]))
    if meta.get("chattering"):  # one line: the worst joint, and what to do where it was tried
        from robodyn.sim.chatter import warning_line as chatter_line

        print(chatter_line(meta["chattering"]))
    print(f"power: average {s['average_power']:.6g} W (W_input over {s['t_final'] - float(trajectory.t[0]):g} s)")
    for line in constraint_lines(trajectory, effort):
        print(line)
    for label, path in (("trajectory", out), ("CSV", csv)):
        if path is not None:
            print(f"wrote {label} {path}")
