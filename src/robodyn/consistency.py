"""Physical consistency of a model's inertials: what a real body can and cannot have."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

# Relative slack for the eigenvalue and triangle-inequality tests: URDF inertias are often
# printed with 4-6 significant digits, so a violation smaller than this is rounding.
RELATIVE_SLACK = 1e-6


@dataclass(frozen=True)
class Finding:
    """One physical-consistency finding about a body of the model."""

    body: str
    severity: str  # "error" (impossible) or "warning" (suspicious)
    message: str

    def __str__(self) -> str:
        return f"{self.body}: {self.message}"


def _body_name(model: pin.Model, joint_id: int) -> str:
    for frame in model.frames:
        if frame.parentJoint == joint_id and frame.type == pin.FrameType.BODY:
            return str(frame.name)
    return str(model.names[joint_id])


def inertial_findings(model: pin.Model) -> list[Finding]:
    """All findings: non-positive mass, non-PSD inertia, triangle inequality, massless links."""
    findings: list[Finding] = []
    for joint_id in range(1, model.njoints):
        inertia = model.inertias[joint_id]
        name = _body_name(model, joint_id)
        mass = float(inertia.mass)
        I = np.array(inertia.inertia)
        scale = max(float(np.abs(I).max()), 1e-300)
        if mass < 0:
            findings.append(Finding(name, "error", f"negative mass {mass:g} kg (expected > 0)"))
        elif mass == 0:
            findings.append(Finding(name, "warning", "moving body with zero mass (its joint carries no inertia)"))
        eig = np.linalg.eigvalsh(0.5 * (I + I.T))
        if eig.min() < -RELATIVE_SLACK * scale:
            findings.append(
                Finding(name, "error", f"inertia not positive semi-definite (eigenvalues {np.array2string(eig, precision=4)} kg m^2)")
            )
        else:
            d = np.diag(I)
            for i, (a, b, c) in enumerate(((1, 2, 0), (0, 2, 1), (0, 1, 2))):
                if d[a] + d[b] < d[c] - RELATIVE_SLACK * scale:
                    axes = "xyz"
                    findings.append(
                        Finding(
                            name,
                            "error",
                            f"inertia breaks the triangle inequality I{axes[a]*2} + I{axes[b]*2} >= I{axes[c]*2} "
                            f"({d[a]:.6g} + {d[b]:.6g} < {d[c]:.6g} kg m^2)",
                        )
                    )
        if mass > 0 and np.all(eig <= 0):
            findings.append(Finding(name, "warning", "body with mass but zero rotational inertia (a point mass)"))
    return findings


def impossible_inertials(model: pin.Model) -> list[Finding]:
    """The findings that no real body can have."""
    return [f for f in inertial_findings(model) if f.severity == "error"]
