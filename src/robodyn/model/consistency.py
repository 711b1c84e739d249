"""Physical consistency of a model: what a real body, joint and file can and cannot have.

Findings come in two severities: ``"error"`` (no real body has it: :func:`robodyn.load`
refuses such a model unless ``check_physics=False``) and ``"warning"`` (legal but
suspicious, or a file that is missing). Each carries a short ``code`` for machines:

=================  =======  ====================================================
code               level    meaning
=================  =======  ====================================================
negative_mass      error    a body's mass is below zero
inertia_not_psd    error    a rotational inertia with a negative eigenvalue
triangle           error    principal moments break I1 + I2 >= I3
zero_mass          warning  a moving body with zero mass
massless_subtree   error    a joint that moves nothing with mass or inertia: M is singular
inertia_singular   warning  a body with mass whose inertia is not positive definite
negative_joint     error    negative armature, damping or friction on a joint
limits_reversed    error    a joint's lower position limit is above its upper one
mesh_missing       warning  a mesh file the URDF refers to does not exist
inertia_missing    error    an <inertial> with a mass and no <inertia>: read as a point mass
welded_root        note     an impossible inertia on a link welded to the fixed base: the
                            dynamics never sees it (with a free flyer it is an error)
massless_inertia   note     a link of zero mass with a non-zero inertia: read literally
=================  =======  ====================================================

Inertias are checked per Pinocchio body (the links welded to one joint, merged), which is
what the dynamics sees; a moving body may have zero mass as long as its subtree has some. Each
link's own ``<inertial>`` in the file is checked too (:func:`link_findings`): the merge of
welded links can hide a negative mass, and the root link's body is not a joint's. The triangle
inequality is tested on the principal moments (the eigenvalues of the tensor), not its diagonal:
I1 + I2 >= I3 for the two smallest, which holds in every frame for a real mass distribution.
On a fixed base, the root link and the links welded to it by fixed joints are the world itself:
their inertia cannot change the dynamics, so an impossible one there (anymal's placeholder
``base``) is a note, not a refusal.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from robodyn.model.urdf import parse_numbers

# Relative slack for the eigenvalue and triangle-inequality tests: URDF inertias are often
# printed with 4-6 significant digits, so a violation smaller than this is rounding.
RELATIVE_SLACK = 1e-6

# Absolute slack [kg m^2] on the same tests and the floor below which an inertia counts as
# zero: 1e-12 kg m^2 is a 1 g bead at 30 um radius; URDF exporters leave 1e-18 dust.
INERTIA_FLOOR = 1e-12


@dataclass(frozen=True)
class Finding:
    """One physical-consistency finding about a body, joint or file of the model."""

    body: str
    severity: str  # "error" (impossible) or "warning" (suspicious)
    message: str
    code: str = ""

    def __str__(self) -> str:
        return f"{self.body}: {self.message}"

    def as_dict(self) -> dict[str, str]:
        """The finding as plain JSON-able values."""
        return {"where": self.body, "severity": self.severity, "code": self.code, "message": self.message}


def _body_name(model: pin.Model, joint_id: int) -> str:
    for frame in model.frames:
        if frame.parentJoint == joint_id and frame.type == pin.FrameType.BODY:
            return str(frame.name)
    return str(model.names[joint_id])


def _inertia_findings(name: str, mass: float, I: np.ndarray) -> list[Finding]:
    findings: list[Finding] = []
    slack = max(RELATIVE_SLACK * float(np.abs(I).max()), INERTIA_FLOOR)
    if mass < 0:
        findings.append(Finding(name, "error", f"negative mass {mass:g} kg (expected > 0)", "negative_mass"))
    eig = np.linalg.eigvalsh(0.5 * (I + I.T))
    if eig.min() < -slack:
        findings.append(
            Finding(
                name,
                "error",
                f"inertia not positive semi-definite (eigenvalues {np.array2string(eig, precision=4)} kg m^2)",
                "inertia_not_psd",
            )
        )
        return findings
    if eig[0] + eig[1] < eig[2] - slack:  # eigvalsh sorts ascending: the one inequality that can fail
        findings.append(
            Finding(
                name,
                "error",
                f"principal moments of inertia {eig[0]:.6g}, {eig[1]:.6g}, {eig[2]:.6g} kg m^2 break the "
                f"triangle inequality ({eig[0]:.6g} + {eig[1]:.6g} < {eig[2]:.6g})",
                "triangle",
            )
        )
    if mass > 0 and eig.min() <= slack:
        what = "a point mass" if eig.max() <= INERTIA_FLOOR else "a thin rod or flat plate"
        findings.append(
            Finding(
                name,
                "warning",
                f"inertia not positive definite (eigenvalues {np.array2string(eig, precision=4)} kg m^2): {what}",
                "inertia_singular",
            )
        )
    return findings


@dataclass(frozen=True)
class LinkInertial:
    """One link's ``<inertial>`` as written in the file (zeros for a link without one)."""

    link: str
    mass: float  # [kg]
    xyz: tuple[float, float, float]  # [m] centre of mass in the link frame
    rpy: tuple[float, float, float]  # [rad] orientation of the inertia's frame in the link frame
    inertia: np.ndarray  # (3, 3) [kg m^2] about the centre of mass, in the inertial frame
    inertia_written: bool = True  # False: an <inertial> with a mass but no <inertia> (read as zero)


def _vector(element: ET.Element | None, attribute: str) -> tuple[float, float, float]:
    values = parse_numbers(element.get(attribute, "0 0 0"), 3) if element is not None else None
    return (values[0], values[1], values[2]) if values else (0.0, 0.0, 0.0)


def _scalar(element: ET.Element | None, attribute: str) -> float:
    values = parse_numbers(element.get(attribute, "0"), 1) if element is not None else None
    return values[0] if values else 0.0


def link_inertials(root: ET.Element) -> list[LinkInertial]:
    """Every link's inertial in ``root``, in file order (a number that does not parse reads as 0: validate first)."""
    out = []
    for link in root.findall("link"):
        inertial = link.find("inertial")
        mass, I = 0.0, np.zeros((3, 3))
        if inertial is not None:
            mass = _scalar(inertial.find("mass"), "value")
            element = inertial.find("inertia")
            t = {n: _scalar(element, n) for n in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
            I = np.array(
                [[t["ixx"], t["ixy"], t["ixz"]], [t["ixy"], t["iyy"], t["iyz"]], [t["ixz"], t["iyz"], t["izz"]]]
            )
        origin = inertial.find("origin") if inertial is not None else None
        written = inertial is None or inertial.find("inertia") is not None
        out.append(
            LinkInertial(str(link.get("name")), mass, _vector(origin, "xyz"), _vector(origin, "rpy"), I, written)
        )
    return out


def welded_to_root(root: ET.Element) -> set[str]:
    """The root link of the URDF ``root`` and every link welded to it by fixed joints only.

    On a fixed base they are the world: Pinocchio merges them into the universe, which never moves.
    """
    children: dict[str, list[tuple[str, str]]] = {}
    has_parent: set[str] = set()
    for joint in root.findall("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        if parent is None or child is None:
            continue
        children.setdefault(str(parent.get("link")), []).append((str(joint.get("type")), str(child.get("link"))))
        has_parent.add(str(child.get("link")))
    tops = [str(link.get("name")) for link in root.findall("link") if link.get("name") not in has_parent]
    welded = set(tops[:1])
    stack = list(welded)
    while stack:
        for kind, below in children.get(stack.pop(), ()):
            if kind == "fixed" and below not in welded:
                welded.add(below)
                stack.append(below)
    return welded


def link_findings(inertials: Sequence[LinkInertial], *, welded: Collection[str] = ()) -> list[Finding]:
    """The errors of each link's own inertial as written in the file (before any merge of welded links).

    An error on a link of ``welded`` (the links fixed to a fixed base, :func:`welded_to_root`) is a
    ``welded_root`` note instead: the dynamics never sees that inertia.
    """
    findings: list[Finding] = []
    for link in inertials:
        for f in _inertia_findings(link.link, link.mass, link.inertia) + _unwritten(link):
            if f.severity != "error":
                continue
            if link.link in welded:
                f = Finding(
                    f.body,
                    "note",
                    f"{f.message}: welded to the fixed base, so it does not enter the dynamics "
                    "(with --free-flyer it would, and the model is refused)",
                    "welded_root",
                )
            findings.append(f)
    return findings


def _unwritten(link: LinkInertial) -> list[Finding]:
    if link.inertia_written or link.mass == 0:
        return []
    message = f"<inertial> has a mass of {link.mass:g} kg but no <inertia> (read as a point mass, zero inertia)"
    return [Finding(link.link, "error", message, "inertia_missing")]


def massless_inertia_findings(inertials: Sequence[LinkInertial]) -> list[Finding]:
    """A note for each link of zero mass whose inertia is not zero (bolt's feet): robodyn reads it as written."""
    return [
        Finding(
            link.link,
            "note",
            f"mass 0 kg with a non-zero inertia (largest term {float(np.abs(link.inertia).max()):.3g} kg m^2): "
            "robodyn reads it literally (a body that resists rotation but not translation), while other "
            "engines substitute a mass (Drake gives a link of zero mass 1 kg)",
            "massless_inertia",
        )
        for link in inertials
        if link.mass == 0 and float(np.abs(link.inertia).max()) > INERTIA_FLOOR
    ]


def is_free_flyer(model: pin.Model) -> bool:
    """True when the model's root is mounted on a free-flyer joint."""
    return model.njoints > 1 and int(model.parents[1]) == 0 and "FreeFlyer" in model.joints[1].shortname()


def file_findings(urdf: Path, *, free_flyer: bool = False) -> list[Finding]:
    """:func:`link_findings` and :func:`massless_inertia_findings` of the URDF file ``urdf``.

    On a fixed base (``free_flyer`` False) the links welded to the root are notes (see :func:`link_findings`).
    """
    from robodyn.model.files import read_xml

    root = read_xml(urdf, "URDF")
    inertials = link_inertials(root)
    welded = () if free_flyer else welded_to_root(root)
    return link_findings(inertials, welded=welded) + massless_inertia_findings(inertials)


def _distinct(findings: list[Finding]) -> list[Finding]:
    """``findings`` without repeats of a (body, code) pair: a lone link is also its own body."""
    seen: set[tuple[str, str]] = set()
    out = []
    for finding in findings:
        if (finding.body, finding.code) not in seen:
            seen.add((finding.body, finding.code))
            out.append(finding)
    return out


def _subtree_has_inertia(model: pin.Model) -> list[bool]:
    """For each joint: does its subtree carry any mass or rotational inertia?"""
    has = [False] * model.njoints
    for j in range(model.njoints - 1, 0, -1):
        inertia = model.inertias[j]
        own = float(inertia.mass) > 0 or float(np.abs(np.array(inertia.inertia)).max()) > INERTIA_FLOOR
        has[j] = has[j] or own
        parent = int(model.parents[j])
        has[parent] = has[parent] or has[j]
    return has


def inertial_findings(model: pin.Model) -> list[Finding]:
    """Findings about the bodies: mass, positive (semi-)definiteness, triangle inequality, massless."""
    findings: list[Finding] = []
    subtree = _subtree_has_inertia(model)
    for joint_id in range(1, model.njoints):
        inertia = model.inertias[joint_id]
        name = _body_name(model, joint_id)
        mass = float(inertia.mass)
        findings += _inertia_findings(name, mass, np.array(inertia.inertia))
        if mass == 0 and model.joints[joint_id].nv > 0:
            findings.append(Finding(name, "warning", "moving body with zero mass", "zero_mass"))
        armature = np.asarray(model.armature)[model.joints[joint_id].idx_v : model.joints[joint_id].idx_v + 1]
        if not subtree[joint_id] and not np.any(armature > 0):
            findings.append(
                Finding(
                    str(model.names[joint_id]),
                    "error",
                    "joint moves no mass, inertia or armature: the mass matrix is singular",
                    "massless_subtree",
                )
            )
    return findings


def joint_findings(model: pin.Model) -> list[Finding]:
    """Findings about the joints: negative armature, damping, friction; reversed limits."""
    findings: list[Finding] = []
    for joint_id in range(1, model.njoints):
        joint = model.joints[joint_id]
        name = str(model.names[joint_id])
        vs = slice(joint.idx_v, joint.idx_v + joint.nv)
        for what, values in (
            ("armature", model.armature),
            ("damping", model.damping),
            ("friction", model.friction),
        ):
            bad = np.asarray(values)[vs]
            if np.any(bad < 0):
                findings.append(
                    Finding(name, "error", f"negative {what} {bad.min():g} (expected >= 0)", "negative_joint")
                )
        if joint.nq == joint.nv:
            qs = slice(joint.idx_q, joint.idx_q + joint.nq)
            lower, upper = np.asarray(model.lowerPositionLimit)[qs], np.asarray(model.upperPositionLimit)[qs]
            if np.any(lower > upper):
                findings.append(
                    Finding(
                        name,
                        "error",
                        f"lower position limit {lower.max():g} is above the upper one {upper.min():g}",
                        "limits_reversed",
                    )
                )
    return findings


def mesh_findings(urdf: Path) -> list[Finding]:
    """One warning per mesh file the URDF names that cannot be found (no mesh is parsed)."""
    from robodyn.model.files import mesh_references

    return [
        Finding(ref.link, "warning", f"{ref.kind} mesh {ref.uri!r} not found", "mesh_missing")
        for ref in mesh_references(urdf)
        if ref.path is None
    ]


def all_findings(model: pin.Model, *, urdf: Path | None = None, geometry: bool = False) -> list[Finding]:
    """Every finding about ``model`` and, given ``urdf``, its file's links; meshes only when ``geometry``."""
    findings = inertial_findings(model) + joint_findings(model)
    if urdf is not None:
        findings += file_findings(urdf, free_flyer=is_free_flyer(model))
        if geometry:
            findings += mesh_findings(urdf)
    return _distinct(findings)


def impossible_inertials(
    model: pin.Model, *, links: Sequence[LinkInertial] = (), welded: Collection[str] = ()
) -> list[Finding]:
    """The findings that no real body can have, in ``model`` and in the file's ``links``.

    ``welded``: the links fixed to a fixed base (:func:`welded_to_root`), whose inertia the dynamics never sees.
    """
    findings = inertial_findings(model) + joint_findings(model) + link_findings(links, welded=welded)
    return _distinct([f for f in findings if f.severity == "error"])
