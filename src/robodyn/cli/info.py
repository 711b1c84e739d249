"""``robodyn info URDF_OR_NAME``: joints, links, sizes, mass, joint parameters and findings."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from robodyn.cli._common import add_physics_argument, file_path, physics_checked, print_json, warn_unchecked
from robodyn.cli._parse import parse_keep, parse_lock
from robodyn.errors import InputError
from robodyn.kinds import catalog


def add_parser(sub: Any) -> None:
    """Register ``robodyn info``."""
    p = sub.add_parser(
        "info",
        help="describe a robot: joints, links, nq, nv, mass, armature, damping, physical findings",
        description="Describe a robot: every joint (type, axis, limits, actuated or passive, armature, rotor "
        "parameters, damping), every link and its mass, nq, nv, the total mass, and the physical-consistency "
        "findings (non-positive mass, inertia not positive definite or breaking the triangle inequality, moving "
        "links without mass, missing meshes with --geometry, and a link whose geometry is one box, cylinder or "
        "sphere but whose inertia differs by more than 1 % from that primitive's at uniform density, a note). "
        "Exit code 0 even when findings are listed. "
        "--list names every model reachable by name instead.",
    )
    p.add_argument(
        "model",
        metavar="URDF_OR_NAME",
        nargs="?",
        default=None,
        help=f"built-in model ({catalog.listed()}), an example-robot-data robot (panda, talos, ...) "
        "or a path to a .urdf file",
    )
    p.add_argument("--srdf", type=file_path, default=None, help="SRDF file (default: same stem as the URDF)")
    p.add_argument("--free-flyer", action="store_true", help="mount the root on a free-flyer joint")
    add_physics_argument(p)  # info never refuses a model for its physics: it lists the findings
    p.add_argument(
        "--list", action="store_true", help="list every model reachable by name (built-in, example-robot-data)"
    )
    add_reduction_arguments(p)
    p.add_argument("--mimic", action="store_true", help="keep URDF mimic joints as mimic joints")
    p.add_argument("--geometry", action="store_true", help="also look for every mesh file the URDF names")
    p.add_argument("--json", action="store_true", help="print the same as JSON")
    p.set_defaults(handler=run)


def add_reduction_arguments(p: argparse.ArgumentParser) -> None:
    """``--lock``, ``--keep`` and ``--reference``: build the minimal model of a scene."""
    p.add_argument(
        "--lock",
        metavar="NAME=VALUE,...",
        default=None,
        help="lock these joints at these values [rad | m] (pinocchio.buildReducedModel)",
    )
    p.add_argument("--keep", metavar="NAME,...", default=None, help="keep only these joints; lock every other one")
    p.add_argument(
        "--reference",
        metavar="STATE",
        default=None,
        help="SRDF group state (e.g. half_sitting) at which locked joints are held (default: neutral)",
    )


def load_reduced(args: argparse.Namespace, **options: Any) -> Any:
    """Load ``args.model`` with the common options and ``--lock`` / ``--keep`` / ``--reference``."""
    from robodyn.model.load import load

    lock = parse_lock(args.lock) if args.lock is not None else None
    keep = parse_keep(args.keep) if args.keep is not None else None
    reducing = lock is not None or keep is not None
    return load(
        args.model,
        srdf=args.srdf,
        free_flyer=args.free_flyer,
        lock=lock,
        keep=keep,
        reference=args.reference if reducing else None,
        **options,
    )


def run(args: argparse.Namespace) -> int:
    """Print the summary of the robot."""
    from robodyn.model.files import looks_like_path
    from robodyn.model.sources import resolve
    from robodyn.model.summary import summarize

    if args.list:
        if args.model is not None:
            raise InputError("--list names every model; leave out the model")
        return _list_models(as_json=args.json)
    if args.model is None:
        raise InputError("robodyn info needs a model (a name or a .urdf path), or --list to name them all")
    robot = load_reduced(args, mimic=args.mimic, check_physics=False)
    if not physics_checked(args):
        warn_unchecked(robot, command="info")
    hint = False if looks_like_path(args.model) else resolve(args.model).free_flyer_hint
    summary = summarize(robot, geometry=args.geometry, free_flyer_hint=hint)
    if args.json:
        out = summary.as_dict()
        if args.lock is not None or args.keep is not None:
            out["reduced_from"] = {"lock": args.lock, "keep": args.keep, "reference": args.reference}
        print_json(out)
    else:
        print(format_summary(summary))
    return 0


def _list_models(*, as_json: bool) -> int:
    """Print every model reachable by name with where it comes from."""
    from robodyn.model.sources import model_sources

    sources = model_sources()
    rows = {name: sources.get(name) for name in sorted(sources.names(), key=str.lower)}
    if as_json:
        print_json(
            {
                name: {"urdf": str(s.urdf), "srdf": str(s.srdf or ""), "description": s.description}
                for name, s in rows.items()
            }
        )
        return 0
    width = max(len(name) for name in rows)
    for name, source in rows.items():
        flyer = " (free flyer in example-robot-data: --free-flyer)" if source.free_flyer_hint else ""
        print(f"{name:{width}s}  {source.description}{flyer}")
    print(f"{len(rows)} models; any .urdf file can be given by path too")
    return 0


def _fmt(values: tuple[float, ...], digits: int = 4) -> str:
    if not values:  # a joint without velocity coordinates (a mimic joint): the column does not apply
        return "-"
    if len(values) == 1:
        return f"{values[0]:.{digits}g}"
    return "[" + " ".join(f"{v:.{digits}g}" for v in values) + "]"


def _mimic_text(mimic: str) -> str:
    """``"joint * 50 + 0"`` -> ``"joint x 50"`` (the offset [rad | m] shown only when not zero)."""
    joint, _, rest = mimic.partition(" * ")
    multiplier, _, offset = rest.partition(" + ")
    try:
        text = f"{joint} x {float(multiplier):g}"
        return text + (f" + {float(offset):g}" if float(offset or 0) != 0 else "")
    except ValueError:
        return mimic


def _limits(lower: tuple[float, ...], upper: tuple[float, ...]) -> str:
    if len(lower) != 1:
        return "-"
    lo, hi = lower[0], upper[0]
    if not (np.isfinite(lo) and np.isfinite(hi)) or max(abs(lo), abs(hi)) > 1e10:
        return "unbounded"
    return f"[{lo:.4g}, {hi:.4g}]"


def _primitive_lines(s: Any) -> list[str]:
    """Each link whose geometry is one primitive, against that primitive's uniform-density inertia."""
    from robodyn.model.summary import PRIMITIVE_RTOL, primitive_text

    if not s.primitives:
        return []
    n = sum(1 for c in s.primitives if c.differs)
    lines = [
        f"Inertia against the link's one primitive at uniform density ({len(s.primitives)} link(s), "
        f"{n} differ by more than {100 * PRIMITIVE_RTOL:g} %):"
    ]
    for c in s.primitives:
        verdict = f"DIFFERS by {100 * c.relative_difference:.3g} % ({c.element})" if c.differs else "agrees"
        lines.append(f"  {c.link:32s} {primitive_text(c.shape, c.size):38s} {c.source:9s}  {verdict}")
    lines.append("")
    return lines


def format_summary(s: Any) -> str:
    """The human-readable report of a :class:`robodyn.model.summary.ModelSummary`."""
    lines = [f"{s.name}: nq = {s.nq}, nv = {s.nv}, total mass = {s.total_mass:.6g} kg (moving {s.moving_mass:.6g} kg)"]
    lines.append(f"  URDF: {s.urdf}")
    lines.append(f"  SRDF: {s.srdf or '-'}")
    if s.free_flyer_hint and not s.free_flyer:
        lines.append("  base: fixed (example-robot-data mounts this robot on a free flyer: add --free-flyer)")
    else:
        lines.append(f"  base: {'free flyer' if s.free_flyer else 'fixed'}")
    lines.append("")
    lines.append(f"Joints ({len(s.joints)}):")
    header = (
        f"  {'name':28s} {'type':10s} {'axis':12s} {'limits':22s} {'vel':>7s} {'effort':>7s} "
        f"{'armature':>9s} {'rotor J':>9s} {'gear':>6s} {'damping':>8s} {'friction':>8s}  drive"
    )
    lines.append(header)
    for j in s.joints:
        axis = " ".join(f"{a:g}" for a in j.axis) if j.axis is not None else "-"
        if j.mimic and j.nv == 0:  # a mimic joint has no velocity of its own: its columns do not apply
            drive = f"mimics {_mimic_text(j.mimic)}"
        else:
            drive = "actuated" if j.actuated else "passive"
            if j.mimic:
                drive += f", URDF mimic of {_mimic_text(j.mimic)} (independent here; --mimic couples it)"
        lines.append(
            f"  {j.name:28s} {j.type:10s} {axis:12s} {_limits(j.lower, j.upper):22s} {_fmt(j.velocity_limit):>7s} "
            f"{_fmt(j.effort_limit):>7s} {_fmt(j.armature):>9s} {_fmt(j.rotor_inertia):>9s} {_fmt(j.gear_ratio):>6s} "
            f"{_fmt(j.damping):>8s} {_fmt(j.friction):>8s}  {drive}"
        )
    lines.append(
        "  units: limits [rad | m], vel [rad/s | m/s], effort [N m | N], armature and rotor J [kg m^2], "
        "damping [N m s/rad | N s/m], friction [N m | N]"
    )
    lines.append("")
    lines.append(f"Links ({len(s.links)}):")
    for link in s.links:
        lines.append(f"  {link.name:32s} {link.mass:10.6g} kg   {('child of ' + link.joint) if link.joint else 'root'}")
    lines.append("")
    lines.extend(_primitive_lines(s))
    if s.skipped_passive:
        lines.append(f"SRDF passive joints not in this model (skipped): {', '.join(s.skipped_passive)}")
    errors = [f for f in s.findings if f.severity == "error"]
    warnings = [f for f in s.findings if f.severity == "warning"]
    notes = [f for f in s.findings if f.severity == "note"]  # inertia_vs_shape: legal, worth knowing
    geometry = "" if s.geometry_checked else " (meshes not checked: add --geometry)"
    if not s.findings:
        lines.append(f"Physical consistency: no findings{geometry}")
    else:
        counts = f"{len(errors)} error(s), {len(warnings)} warning(s)" + (f", {len(notes)} note(s)" if notes else "")
        lines.append(f"Physical consistency: {counts}{geometry}")
        for f in errors + warnings + notes:
            lines.append(f"  {f.severity:7s} {f.code:17s} {f}")
    return "\n".join(lines)
