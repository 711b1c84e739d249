"""Scene files: one small TOML file that says everything a scene needs.

A scene names the model and the joints it moves (the rest are locked, so robodyn builds
the minimal model), the initial state, the torque or controller, how long and how to
integrate, and what to check, benchmark and show. :func:`read_scene` parses and validates
it (every problem is one line naming the file, the table and the key); ``robodyn run``
then builds the model and runs the parts asked for. Example::

    [model]
    name = "panda"                          # or: urdf = "path/to/robot.urdf"
    keep = ["panda_joint2", "panda_joint4", "panda_joint6"]
    reference = "default"                   # SRDF group state holding the locked joints
    passive = []                            # joints without an actuator (besides the SRDF's), e.g. ["joint2"]

    [initial]
    q = { panda_joint2 = 0.3, panda_joint4 = -2.0 }   # by joint name, or a list of nq
    v = [0.0, 0.0, 0.0]

    [control]
    kind = "pd"                             # "none", "constant" or "pd"
    kp = 50.0
    kd = 5.0
    target = { panda_joint2 = 0.0 }
    gravity_compensation = true
    # or kind = "lqr" | "swing_up" with robodyn.control's gains as keys (Q, R, K, q_eq, u_eq, rho,
    # k_energy, ...), e.g. Q = [10, 10, 1, 1] and R = 0.1; or kind = "file" with
    # path = "my_controller.py" (defining make(robot, **gains)) and gains = { kp = 5.0 }

    [simulate]                              # defaults as robodyn simulate: 2 s, 1e-3 s, rk4
    duration = 2.0                          # [s]
    dt = 1e-3                               # [s]
    integrator = "rk4"

    [constraints]                           # defaults: the URDF's stops (e = 0) and efforts
    limits = true
    restitution = 0.0                       # at the stops, in [0, 1]
    effort_limits = true
    loops = [{ frame_a = "bc_tip", frame_b = "collar", kind = "point" }]
    couplings = [{ joint = "spin", leader = "slide", ratio = 6.6667, offset = 0.0 }]

    [springs]                               # joint = { stiffness [N m/rad | N/m], rest [rad | m] }
    joint_a = { stiffness = 5.0, rest = 0.0 }

    [check]                                 # structural identities (and a formula, if named)
    formula = "reduced_formula.py"          # a kind or a file; KIND = "constrained": checked on the loops
    formula_timeout = 60                    # [s] the file's own time per request, as --formula-timeout
    samples = 20
    exactness = true                        # reduced model == full model with locks held
    closed_form = "closed_form.py"          # only this: the motion against the book's closed form
    closed_form_rtol = 1e-9                 # worst deviation allowed (default 1e-6)

    [bench]
    repeat = 200

    [view]
    html = "panda_arm.html"                 # write a standalone player (or: open = true)

Relative paths (``urdf``, ``srdf``, ``output``, ``view.html``, ``check.formula``, ``check.closed_form``,
``control.path``) are read from the scene file's folder.
"""

from robodyn.scene.model import (
    CLOSED_FORM_KEYS,
    CONTROL_KINDS,
    DEFAULT_CLOSED_FORM_RTOL,
    MAX_PORT,
    MAX_REPEAT,
    MAX_SAMPLES,
    MAX_SCENE_BYTES,
    MAX_SEED,
    TABLES,
    Scene,
)
from robodyn.scene.reader import read_scene

__all__ = [
    "CLOSED_FORM_KEYS",
    "CONTROL_KINDS",
    "DEFAULT_CLOSED_FORM_RTOL",
    "MAX_PORT",
    "MAX_REPEAT",
    "MAX_SAMPLES",
    "MAX_SCENE_BYTES",
    "MAX_SEED",
    "TABLES",
    "Scene",
    "read_scene",
]
