"""The one place that calls Pinocchio's constrained algorithms: loop closures and joint couplings.

:mod:`robodyn.dynamics` calls the algorithms of open chains; this module calls the ones that
constrain them, and nothing else does:

* **Loop closures** -- two frames held together, by a point (``"point"``, 3 rows) or rigidly
  (``"6d"``, 6 rows) -- are Pinocchio's legacy ``RigidConstraintModel`` solved by
  ``constraintDynamics``, which returns an acceleration, so every explicit integrator (RK4
  included) steps it. A Baumgarte corrector (``Kp``, ``Kd`` [1/s^2, 1/s]) pulls the drift back.
  A joint held at a stop while loops are present is a 6-D weld of the joint's child to its
  parent at the current placement (:func:`lock_model`); on open chains robodyn holds stops by
  itself (:mod:`robodyn.sim.limits`), exactly and without Pinocchio.
* **Couplings** q_follower = ratio * q_leader + offset are Pinocchio mimic joints
  (``transformJointIntoMimic``); ABA refuses those, so their forward dynamics is CRBA.

Pitfalls met on pin 4.1 (see ``PINOCCHIO_CONSTRAINTS.md``), each handled here once:
``initConstraintDynamics`` takes four arguments; ``constraintDynamics`` needs it first; a
proximal ``mu`` of 0 gives NaN on the rank-deficient Jacobian of a planar loop (``MU`` > 0);
``calc`` and ``getConstraintsJacobian`` read the kinematics already in ``data`` (they are
computed first); with nv = 1 Jacobians come back 1-D (reshaped). ``constraintDynamics``
refuses mimic joints. Every array leaving this module is a fresh copy.

Units: q [rad | m], v [rad/s | m/s], tau [N m | N], residuals [m] (point) or [m, rad] (6d).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

Array = NDArray[np.float64]

KINDS = ("point", "6d")

# Proximal solver of constraintDynamics: absolute accuracy on the constraint acceleration,
# the proximal weight (>= 1e-8: mu = 0 returns NaN on a rank-deficient planar loop), and
# the iteration cap. Measured: 3 iterations on the 19.3 linkage; 1e-12 is ~1e4 ulps of O(1).
ACCURACY = 1e-12
MU = 1e-8
MAX_ITERATIONS = 50


@dataclass(frozen=True)
class Anchor:
    """A point fixed in a body: the joint that moves the body and the placement in its frame."""

    frame: str
    joint: int
    placement: pin.SE3


def frame_names(model: pin.Model) -> tuple[str, ...]:
    """The names of the model's frames (links, joints, fixed joints), universe excluded."""
    return tuple(str(f.name) for f in model.frames if str(f.name) != "universe")


def anchor(model: pin.Model, name: str) -> Anchor | None:
    """The frame ``name`` as (joint, placement), or None when the model has no such frame.

    A link's BODY frame is preferred over a joint frame of the same name.
    """
    found = [f for f in model.frames if str(f.name) == name]
    if not found:
        return None
    body = [f for f in found if f.type == pin.FrameType.BODY]
    frame = (body or found)[0]
    return Anchor(name, int(frame.parentJoint), pin.SE3(frame.placement))


def loop_model(model: pin.Model, kind: str, a: Anchor, b: Anchor, kp: float, kd: float) -> pin.RigidConstraintModel:
    """A loop closure holding anchor ``a`` on anchor ``b``, with Baumgarte gains (kp, kd) > 0.

    ``"point"``: the two points coincide (3 rows, world-aligned: residual p_a - p_b [m]);
    ``"6d"``: the two frames coincide (6 rows, in frame a).
    """
    if kind == "point":
        contact, reference = pin.ContactType.CONTACT_3D, pin.LOCAL_WORLD_ALIGNED
    else:
        contact, reference = pin.ContactType.CONTACT_6D, pin.LOCAL
    cm = pin.RigidConstraintModel(contact, model, a.joint, a.placement, b.joint, b.placement, reference)
    cm.setBaumgarteCorrectorParameters(pin.BaumgarteCorrectorParameters(kp, kd))
    return cm


def lock_model(
    model: pin.Model, data: pin.Data, joint: int, q: Array, kp: float, kd: float
) -> pin.RigidConstraintModel:
    """A 6-D weld that holds ``joint`` where it is at q: its child frame on its parent's.

    Five of its six rows repeat what the joint already imposes; the proximal solver takes
    the rank deficiency.
    """
    pin.forwardKinematics(model, data, q)
    parent = int(model.parents[joint])
    cm = pin.RigidConstraintModel(
        pin.ContactType.CONTACT_6D, model, joint, pin.SE3.Identity(), parent, pin.SE3(data.liMi[joint]), pin.LOCAL
    )
    cm.setBaumgarteCorrectorParameters(pin.BaumgarteCorrectorParameters(kp, kd))
    return cm


class ConstraintSolver:
    """``constraintDynamics`` on a fixed list of constraint models, with its own ``data``.

    Rebuild it whenever the list changes (the data are sized for the list they were made for).
    """

    def __init__(self, model: pin.Model, models: list[pin.RigidConstraintModel]) -> None:
        self.model = model
        self.data = model.createData()
        self.models = list(models)
        self.datas = [cm.createData() for cm in self.models]
        self.rows = int(sum(cm.residualSize() for cm in self.models))
        self.settings = pin.ProximalSettings(ACCURACY, MU, MAX_ITERATIONS)
        pin.initConstraintDynamics(model, self.data, self.models, self.datas)

    def acceleration(self, q: Array, v: Array, tau: Array) -> tuple[Array, bool, float]:
        """(a (nv,), converged, the solver's relative residual) of M a + C v + G = tau + J^T lambda.

        Converged: a finite acceleration within ``MAX_ITERATIONS`` proximal iterations.
        """
        settings = self.settings
        a = np.array(pin.constraintDynamics(self.model, self.data, q, v, tau, self.models, self.datas, settings))
        if settings.iter < settings.max_iter and np.isfinite(a).all():
            return a, True, 0.0
        residual = float(settings.relative_residual)
        return a, bool(np.isfinite(a).all()) and residual <= ACCURACY, residual

    def forces(self) -> Array:
        """The constraint forces lambda (rows,) of the last :meth:`acceleration` [N | N m]."""
        return np.array(self.data.lambda_c).reshape(-1).copy()

    def _update(self, q: Array) -> None:
        pin.computeJointJacobians(self.model, self.data, q)  # forward kinematics too
        for cm, cd in zip(self.models, self.datas, strict=True):
            cm.calc(self.model, self.data, cd)

    def residual(self, q: Array) -> Array:
        """The stacked position residuals (rows,): p_a - p_b [m] (point), -log6(aMb) [m, rad] (6d)."""
        self._update(q)
        parts = []
        for cm, cd in zip(self.models, self.datas, strict=True):
            if cm.type == pin.ContactType.CONTACT_3D:
                parts.append(np.array(cd.oMc1.translation) - np.array(cd.oMc2.translation))
            else:
                parts.append(-np.array(pin.log6(cd.c1Mc2).vector))
        return np.concatenate(parts) if parts else np.zeros(0)

    def jacobian(self, q: Array) -> Array:
        """The stacked constraint Jacobian (rows, nv): the rate of :meth:`residual`.

        Exact for points; for 6-D frames, to first order at zero residual.
        """
        self._update(q)
        J = np.array(pin.getConstraintsJacobian(self.model, self.data, self.models, self.datas))
        return J.reshape(self.rows, self.model.nv).copy()


def couple(model: pin.Model, leader: int, follower: int, ratio: float, offset: float) -> pin.Model:
    """A copy of ``model`` whose joint ``follower`` mimics ``leader``: q_f = ratio q_l + offset.

    The follower leaves q and v (its nq and nv become 0); the leader carries it. The
    follower's armature, damping and friction move onto the leader (times ratio^2, ratio^2
    and |ratio|): Pinocchio keeps only the arrays of the joints that stay.
    """
    jf = model.joints[follower]
    jl = model.joints[leader]
    extra = (
        float(model.armature[jf.idx_v]) * ratio**2,
        float(model.damping[jf.idx_v]) * ratio**2,
        float(model.friction[jf.idx_v]) * abs(ratio),
    )
    coupled = pin.transformJointIntoMimic(model, leader, follower, float(ratio), float(offset))
    i = int(coupled.joints[leader].idx_v)
    for name, value in zip(("armature", "damping", "friction"), extra, strict=True):
        array = np.array(getattr(coupled, name), dtype=np.float64)
        kept = np.array(getattr(model, name), dtype=np.float64)
        # transformJointIntoMimic may or may not drop the follower's entry: rebuild from the source.
        if array.size == coupled.nv:
            array[i] = kept[jl.idx_v] + value
            setattr(coupled, name, array)
    return coupled


def mimic_joints(model: pin.Model) -> list[tuple[int, int, float, float]]:
    """The mimic joints of ``model`` as (follower id, leader id, ratio, offset)."""
    out = []
    followers = list(model.mimicking_joints)
    leaders = list(model.mimicked_joints)
    for follower, leader in zip(followers, leaders, strict=True):
        joint = model.joints[int(follower)].extract()
        out.append((int(follower), int(leader), float(joint.scaling), float(joint.offset)))
    return out
