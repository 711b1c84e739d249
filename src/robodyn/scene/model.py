"""The :class:`Scene`: a validated scene file, and what it builds (model, initial state, torque)."""

from __future__ import annotations

import dataclasses
import reprlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn.control.controllers import LQR_GAINS, REGION_GAINS, SWING_UP_GAINS
from robodyn.errors import InputError, SceneError, UnknownNameError
from robodyn.sim.constraints import Constraints

if TYPE_CHECKING:
    from robodyn.model.reduce import Reduction
    from robodyn.robot import Robot

Array = NDArray[np.float64]

# The keys each controller kind of [control] takes besides kind: its gains as robodyn.control.make takes them.
CONTROL_GAINS: dict[str, tuple[str, ...]] = {
    "lqr": LQR_GAINS,
    "swing_up": LQR_GAINS[:3] + REGION_GAINS + tuple(sorted({k for ks in SWING_UP_GAINS.values() for k in ks})),
    "file": ("path", "gains"),
}
PD_KEYS = ("kp", "kd", "target", "gravity_compensation")

TABLES = {
    "model": ("name", "urdf", "srdf", "free_flyer", "mimic", "physics_check", "passive", "keep", "lock", "reference"),
    "initial": ("q", "v"),
    "control": tuple(dict.fromkeys(("kind", "torque", *PD_KEYS, *(k for ks in CONTROL_GAINS.values() for k in ks)))),
    "simulate": ("duration", "dt", "integrator", "backend"),
    "constraints": ("limits", "restitution", "effort_limits", "loops", "couplings"),
    "springs": (),  # joint names: checked by Constraints
    "check": ("samples", "seed", "formula", "formula_timeout", "exactness", "closed_form", "closed_form_rtol"),
    "bench": ("repeat",),
    "view": ("open", "html", "port"),
    "output": ("dir",),
}
CONTROL_KINDS = ("none", "constant", "pd", "lqr", "swing_up", "file")
CLOSED_FORM_KEYS = ("closed_form", "closed_form_rtol")

# The worst deviation from a [check] closed_form allowed when the scene names none: far above
# what RK4 at 1 ms leaves on the textbook's motions (1e-13 to 1e-9), far below a wrong formula's.
DEFAULT_CLOSED_FORM_RTOL = 1e-6

# Bounds on hostile input: a scene file is a few lines of TOML (a larger one is not parsed);
# [check] samples random states and [bench] repeat timed calls, each at most 100,000; [check]
# seed up to the largest TOML integer; [view] port a TCP port.
MAX_SCENE_BYTES = 1024 * 1024
MAX_SAMPLES = 100_000
MAX_REPEAT = 100_000
MAX_SEED = 2**63 - 1
MAX_PORT = 65535


@dataclass(frozen=True)
class Scene:
    """A validated scene file. Tables the file leaves out are None (not asked for)."""

    path: Path
    model: dict[str, Any]
    initial: dict[str, Any] = field(default_factory=dict)
    control: dict[str, Any] = field(default_factory=dict)
    simulate: dict[str, Any] | None = None
    check: dict[str, Any] | None = None
    bench: dict[str, Any] | None = None
    view: dict[str, Any] | None = None
    output: Path | None = None
    constraints: Constraints = field(default_factory=Constraints)

    @property
    def name(self) -> str:
        """The scene's name: its file stem."""
        return self.path.stem

    @property
    def structural_check(self) -> bool:
        """Whether [check] asks for the identity checks: it has keys beyond closed_form (or none at all)."""
        return self.check is not None and (not self.check or bool(set(self.check) - set(CLOSED_FORM_KEYS)))

    def error(self, table: str, key: str, message: str) -> SceneError:
        """A :class:`SceneError` naming this file, ``[table]`` and ``key``."""
        return SceneError(f"{self.path}: [{table}] {key}: {message}")

    # ----------------------------------------------------------------- model
    def build(self) -> tuple[Robot, Reduction | None]:
        """Load the model and reduce it to the joints the scene keeps.

        Returns the robot to simulate (the reduced one when joints are locked) and the
        :class:`robodyn.model.reduce.Reduction`, or None when nothing is locked.
        """
        from robodyn.errors import UnknownNameError
        from robodyn.model.load import load, load_reduction

        m = self.model
        target = m.get("urdf") or m["name"]
        options = {
            "srdf": m.get("srdf"),
            "free_flyer": m.get("free_flyer", False),
            "mimic": m.get("mimic", False),
            "check_physics": m.get("physics_check", True),  # false: the file's numbers as written
            "passive": tuple(m.get("passive", ())),
        }
        try:
            if not m.get("keep") and not m.get("lock"):
                return load(target, **options), None
            reduction = load_reduction(
                target, lock=m.get("lock"), keep=m.get("keep"), reference=m.get("reference"), **options
            )
        except UnknownNameError as exc:
            raise self.error("model", self._model_key(exc.what), str(exc)) from None
        except SceneError:
            raise
        except InputError as exc:
            raise self.error("model", self._model_key(str(exc)), str(exc)) from None
        return reduction.reduced, reduction

    def _model_key(self, what: str) -> str:
        """The [model] key an error about ``what`` comes from (keep, lock, reference or the model)."""
        from robodyn.model.load import PASSIVE_JOINT

        m = self.model
        if what == PASSIVE_JOINT:
            return "passive"
        if "reference" in what:
            return "reference"
        if ("keep" in what or "kept" in what) and "keep" in m:
            return "keep"
        if "lock" in what and "lock" in m:
            return "lock"
        if "joint" in what:
            return "keep" if "keep" in m else "lock"
        return "name" if "name" in m else "urdf"

    def with_passive(self, names: tuple[str, ...]) -> Scene:
        """This scene with ``names`` added to its [model] passive joints (the command line's ``--passive``)."""
        if not names:
            return self
        passive = tuple(dict.fromkeys((*self.model.get("passive", ()), *names)))
        return dataclasses.replace(self, model={**self.model, "passive": list(passive)})

    def initial_state(self, robot: Robot, reduction: Reduction | None = None) -> tuple[Array, Array]:
        """(q0 (nq,), v0 (nv,)) of the scene for ``robot``, zero velocity by default.

        Joints the scene leaves out start at the reference configuration ([model]
        reference, an SRDF group state) or, without one, at Pinocchio's neutral.
        """
        if reduction is not None:
            default = reduction.reduced_q(reduction.q_reference)
        elif "reference" in self.model:
            from robodyn.model.reduce import reference_configuration

            default = reference_configuration(robot, self.model["reference"])
        else:
            default = robot.neutral()
        q = self._joint_vector(robot, "initial", "q", self.initial.get("q"), default, configuration=True)
        v = self._joint_vector(robot, "initial", "v", self.initial.get("v"), np.zeros(robot.nv), configuration=False)
        return self._follow_couplings(robot, q, v)

    def _follow_couplings(self, robot: Robot, q: Array, v: Array) -> tuple[Array, Array]:
        """A coupled joint that [initial] leaves out starts where its leader puts it (ratio q_l + offset, ratio v_l).

        A list gives every coordinate, so it is left as it is (simulate checks it against the couplings).
        """
        names = set(robot.joint_names)
        for x, key in ((q, "q"), (v, "v")):
            given = self.initial.get(key)
            if isinstance(given, list):
                continue
            named = set(given or {})
            for _ in self.constraints.couplings:  # once per link of the longest chain
                for c in self.constraints.couplings:
                    if c.joint in named or not {c.joint, c.leader} <= names:
                        continue  # an unknown name is refused by simulate, with close matches
                    f, lead = robot.joint(c.joint), robot.joint(c.leader)
                    if f.nq == lead.nq == f.nv == lead.nv == 1:
                        i, j = (f.idx_q, lead.idx_q) if key == "q" else (f.idx_v, lead.idx_v)
                        x[i] = c.ratio * x[j] + (c.offset if key == "q" else 0.0)
        return q, v

    def _joint_vector(
        self, robot: Robot, table: str, key: str, value: Any, default: Array, *, configuration: bool
    ) -> Array:
        from robodyn.robot import joint_coordinates

        if value is None:
            return default.copy()
        size = robot.nq if configuration else robot.nv
        if isinstance(value, list):
            arr = np.asarray(value, dtype=np.float64)
            if arr.shape != (size,):
                raise self.error(
                    table, key, f"expected {size} numbers for {robot.name} ({robot.nv} DoF), got {arr.size}"
                )
            return arr
        out = default.copy()
        for name, entry in value.items():
            if name not in robot.joint_names:
                raise self.error(
                    table,
                    key,
                    f"no joint {reprlib.repr(name)} in the scene's model; joints: {', '.join(robot.joint_names)}",
                )
            joint = robot.joint(name)
            values = np.atleast_1d(np.asarray(entry, dtype=np.float64))
            if configuration:
                try:
                    out[joint.idx_q : joint.idx_q + joint.nq] = joint_coordinates(joint.kind, joint.nq, values)
                except InputError as exc:
                    raise self.error(table, f"{key}.{name}", str(exc)) from None
            else:
                if values.size != joint.nv:
                    raise self.error(table, f"{key}.{name}", f"expected {joint.nv} number(s), got {values.size}")
                out[joint.idx_v : joint.idx_v + joint.nv] = values
        return out

    # ----------------------------------------------------------------- control
    def torque(
        self, robot: Robot, reduction: Reduction | None = None
    ) -> Array | Callable[[float, Array, Array], Array] | None:
        """The input: None, a constant (nv,) vector [N m | N], or a controller tau(t, q, v).

        ``pd`` is tau = kp (q* - q) - kd v (+ G(q) with ``gravity_compensation``), on the
        actuated joints only (passive joints get zero). q* is ``target`` (the initial q
        by default). ``lqr`` and ``swing_up`` are :func:`robodyn.control.make`'s with the table's
        gains; ``file`` is a user's controller file (``path``) given the ``gains`` table.
        """
        c = self.control
        kind = c.get("kind", "constant" if "torque" in c else "none")
        if kind == "none":
            return None
        if kind in CONTROL_GAINS:
            return self._controller(robot, kind)
        actuated = robot.actuated
        if kind == "constant":
            tau = self._joint_vector(
                robot, "control", "torque", c.get("torque"), np.zeros(robot.nv), configuration=False
            )
            if np.any(tau[~actuated] != 0):
                raise self.error(
                    "control", "torque", f"passive joints {', '.join(robot.passive_joints)} take no torque"
                )
            return tau
        q0, _ = self.initial_state(robot, reduction)
        target = self._joint_vector(robot, "control", "target", c.get("target"), q0, configuration=True)
        kp, kd = float(c.get("kp", 0.0)), float(c.get("kd", 0.0))
        compensate = bool(c.get("gravity_compensation", False))
        mask = actuated.astype(np.float64)

        def controller(t: float, q: Array, v: Array) -> Array:
            from robodyn import dynamics

            error = dynamics.difference(robot.model, q, target)
            tau = kp * error - kd * v
            if compensate:
                tau = tau + robot.G(q)
            return mask * tau

        return controller

    def _controller(self, robot: Robot, kind: str) -> Callable[[float, Array, Array], Array]:
        """The controller of [control] kind = "lqr" | "swing_up" | "file"; its errors name the scene's key."""
        from robodyn import control

        c = self.control
        if kind == "file":
            name, gains = str(c["path"]), dict(c.get("gains", {}))
        else:
            name, gains = kind, {k: c[k] for k in CONTROL_GAINS[kind] if k in c}
        try:
            return control.make(name, robot, **gains)
        except UnknownNameError as exc:  # a gain this robot's controller does not take
            key = f"gains.{exc.name}" if kind == "file" else str(exc.name)
            raise self.error("control", key, str(exc)) from None
        except InputError as exc:
            raise self.error("control", _key_named(str(exc), kind, gains), str(exc)) from None


def _key_named(message: str, kind: str, gains: dict[str, Any]) -> str:
    """The [control] key a controller's error is about: a gain the message names, else path or kind."""
    if kind == "file":
        return "path"
    words = set(message.replace(",", " ").replace(":", " ").split())
    for key in gains:
        if key in words:
            return key
    if "equilibrium" in message and "q_eq" in gains:
        return "q_eq"
    return "kind"
