"""Fuzz families of the files a user hands robodyn besides models and scenes (imported by ``benchmarks/fuzz.py``).

* ``trajectory``: a real saved run (the campaign's ``t.npz``) mutated (arrays of the wrong rank,
  length or dtype, scalars, object arrays, NaN and infinities, 1e308 torques, a declared shape
  larger than its data, times constant, repeated or going back, metadata of the wrong types,
  joint names of another model), played by ``robodyn view pendubot FILE.npz --html v.html``;
* ``controller``: a controller file (``os._exit`` at import, in ``make`` or in ``tau``, endless
  loops, exceptions, writes into q or v, returns of the wrong shape or type, NaN torques, and
  valid ones) given to ``simulate --controller`` or to a scene's ``[control] kind = "file"``;
* ``gains``: ``simulate --controller lqr --gains JSON`` with hostile values (null, booleans,
  strings, NaN, 1e400, shapes);
* ``formula``: the Pendubot formula file of the examples mutated (complex, object, 2**70,
  strings, wrong shapes, exceptions, ``os._exit``, loops) through ``robodyn check``;
* ``json``: every ``--json`` output (diverging runs included) parsed by a strict parser;
* ``srdf``: the Pendubot's SRDF with rotor parameters, mutated (numbers, joints, XML), through
  ``info --json``, ``simulate`` and ``check``; an accepted file must give the armature J n^2 and
  the passive joints it says (read independently with lxml).

Each case says what must happen (``expect``: "accept" or "refuse"); :func:`execute` runs it and
returns its findings: exit 0 where a refusal was due (silently wrong), a refusal of a valid file,
a page or a JSON output with NaN in it, a trajectory file that does not hold the run.
"""

from __future__ import annotations

import io
import json
import math
import re
import sys
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
KINDS = {"trajectory": 4, "controller": 3, "gains": 1, "formula": 2, "json": 1, "srdf": 2}
"""Kind -> weight (cases per 20 drawn, beside fuzz.py's own 20)."""
OK, REFUSE = "accept", "refuse"


def make(kind: str, index: int, pick: Any, fixtures: dict[str, bytes]) -> dict[str, Any]:
    """The fields of a case of ``kind`` (all but ``index`` and ``kind``)."""
    return {"trajectory": _trajectory, "controller": _controller, "gains": _gains, "formula": _formula,
            "json": _json_case, "srdf": _srdf}[kind](pick, fixtures)  # fmt: skip


def _case(family: str, label: str, command: str, files: dict[str, bytes], argv: list[str], **oracle: Any) -> dict:
    return {"family": family, "label": label, "command": command, "files": files, "argv": argv,
            "compare": False, "oracle": oracle}  # fmt: skip


# ============================================================================ trajectories


def _arrays(fixtures: dict[str, bytes]) -> dict[str, np.ndarray]:
    with np.load(io.BytesIO(fixtures["t.npz"])) as npz:
        return {k: npz[k] for k in npz.files}


def _npz(arrays: dict[str, Any]) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def _huge_shape(arrays: dict[str, np.ndarray], name: str, shape: tuple[int, ...]) -> bytes:
    """An .npz whose ``name`` declares ``shape`` over a few bytes of data (np.load would allocate it all)."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for key, value in arrays.items():
            member = io.BytesIO()
            if key == name:
                np.lib.format.write_array_header_1_0(member, {"descr": "<f8", "fortran_order": False, "shape": shape})
                member.write(b"\0" * 64)
            else:
                np.lib.format.write_array(member, np.asarray(value), allow_pickle=True)
            archive.writestr(f"{key}.npy", member.getvalue())
    return buffer.getvalue()


ARRAY_NAMES = ("t", "q", "v", "a", "tau", "kinetic", "potential", "work_input", "work_damping", "work_limits")
TRAJECTORY_OPS = [
    "valid", "valid float32", "valid int", "valid extra array", "valid no work_limits", "valid one sample",
    "3-D", "flattened", "one row", "scalar", "empty", "row dropped", "row added", "column added",
    "complex", "object", "string", "bool", "structured", "nan one", "nan all", "inf one", "-inf all",
    "1e308", "huge shape", "huge shape 2-D", "t constant", "t repeated", "t reversed", "t nan", "t empty",
    "joint names other", "joint names not a list", "joint names numbers", "metadata list", "metadata not json",
    "metadata missing", "metadata object array", "status bogus", "meta list", "wall time text", "evaluations -1",
    "array missing", "(n, 1) energy",
]  # fmt: skip


def _trajectory(pick: Any, fixtures: dict[str, bytes]) -> dict[str, Any]:
    arrays = _arrays(fixtures)
    op = pick.choice(TRAJECTORY_OPS)
    name = pick.choice(ARRAY_NAMES)
    label = op if op.startswith(("valid", "t ", "joint", "meta", "status", "wall", "evaluations", "huge")) else \
        f"{op} {name}"  # fmt: skip
    info = json.loads(str(arrays["metadata"]))
    expect = OK if op.startswith("valid") else REFUSE
    x = np.asarray(arrays[name])
    data: bytes | None = None
    if op == "valid float32":
        arrays[name] = x.astype(np.float32)
    elif op == "valid int":
        arrays["work_limits"] = arrays["work_limits"].astype(np.int64)
    elif op == "valid extra array":
        arrays["notes"] = np.arange(3.0)
    elif op == "valid no work_limits":
        arrays.pop("work_limits")
    elif op == "valid one sample":
        arrays = {k: (v[:1] if k not in ("metadata",) and np.ndim(v) else v) for k, v in arrays.items()}
    elif op == "3-D":
        arrays[name] = x[..., None, None] if x.ndim == 1 else x[..., None]
    elif op == "flattened":
        arrays[name] = x.ravel() if x.ndim > 1 else x[:, None]
    elif op == "one row":
        arrays[name] = x[0]
    elif op == "scalar":
        arrays[name] = np.float64(1.5)
    elif op == "empty":
        arrays[name] = x[:0]
    elif op == "row dropped":
        arrays[name] = x[:-1]
    elif op == "row added":
        arrays[name] = np.concatenate([x, x[-1:] + (1.0 if name == "t" else 0.0)])
    elif op == "column added":
        arrays[name] = np.concatenate([x, x[:, :1]], axis=1) if x.ndim == 2 else np.stack([x, x], axis=1)
    elif op == "complex":
        arrays[name] = x.astype(np.complex128) * (1 + 1e-3j)
    elif op == "object":
        arrays[name] = x.astype(object)
    elif op == "string":
        arrays[name] = x.astype(str)
    elif op == "bool":
        arrays[name] = x != 0
    elif op == "structured":
        arrays[name] = np.zeros(len(x), dtype=[("a", "<f8"), ("b", "<i4")])
    elif op in ("nan one", "inf one"):
        y = x.astype(np.float64).copy()
        y.reshape(-1)[pick.integer(0, y.size - 1)] = np.nan if op == "nan one" else np.inf
        arrays[name] = y
    elif op in ("nan all", "-inf all"):
        arrays[name] = np.full_like(x, np.nan if op == "nan all" else -np.inf, dtype=np.float64)
    elif op == "1e308":
        arrays["tau"] = np.full_like(arrays["tau"], 1e308)
    elif op in ("huge shape", "huge shape 2-D"):
        shape = (10**12,) if op == "huge shape" else (len(arrays["t"]), 10**11)
        data = _huge_shape(arrays, "t" if op == "huge shape" else "q", shape)
    elif op == "t constant":
        arrays["t"] = np.zeros_like(arrays["t"])
    elif op == "t repeated":
        t = arrays["t"].copy()
        k = pick.integer(1, len(t) - 1)
        t[k] = t[k - 1]
        arrays["t"] = t
    elif op == "t reversed":
        arrays["t"] = arrays["t"][::-1].copy()
    elif op == "t nan":
        t = arrays["t"].copy()
        t[pick.integer(0, len(t) - 1)] = np.nan
        arrays["t"] = t
    elif op == "t empty":
        arrays = {k: (v[:0] if k != "metadata" and np.ndim(v) else v) for k, v in arrays.items()}
    elif op.startswith(("joint names", "status", "meta list", "wall", "evaluations")):
        meta = info["meta"]
        if op == "joint names other":
            meta["joint_names"] = ["shoulder", "elbow"]
        elif op == "joint names not a list":
            meta["joint_names"] = "joint1,joint2"
        elif op == "joint names numbers":
            meta["joint_names"] = [1, 2]
        elif op == "status bogus":
            info["status"] = pick.choice(["bogus", 3, None])
        elif op == "meta list":
            info["meta"] = [1, 2]
        elif op == "wall time text":
            info["wall_time_s"] = "fast"
        else:
            info["evaluations"] = pick.choice([-1, 1.5, "x", True])
        arrays["metadata"] = np.array(json.dumps(info))
    elif op == "metadata list":
        arrays["metadata"] = np.array(json.dumps([1, 2]))
    elif op == "metadata not json":
        arrays["metadata"] = np.array("{not json")
    elif op == "metadata missing":
        arrays.pop("metadata")
    elif op == "metadata object array":
        arrays["metadata"] = np.array([json.dumps(info)], dtype=object)
    elif op == "array missing":
        arrays.pop(name)
        expect = OK if name == "work_limits" else REFUSE
    elif op == "(n, 1) energy":
        key = pick.choice(["kinetic", "potential", "work_input", "work_damping", "work_limits"])
        arrays[key] = arrays[key][:, None]
        label = f"{op} {key}"
    files = {"model.urdf": fixtures["model.urdf"], "traj.npz": data if data is not None else _npz(arrays)}
    argv = ["view", "pendubot", "traj.npz", "--html", "v.html"]
    return _case(f"trajectory {op}", label, "view", files, argv, expect=expect)


def _page_findings() -> list[str]:
    """What is wrong with ``v.html`` (written on exit 0): NaN or Infinity in its JSON, or no page at all."""
    page = Path("v.html")
    if not page.exists():
        return ["exit 0 but no page written"]
    text = page.read_text(encoding="utf-8")
    found = re.search(r'<script type="application/json" id="robodyn-info">(.*?)</script>', text, re.S)
    if found is None:
        return ["the page has no chart data"]
    try:
        json.loads(found.group(1).replace("<\\/", "</"), parse_constant=_refuse_constant)
    except ValueError as exc:
        return [f"the page's JSON is not strict JSON: {exc}"]
    return []


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"{name} in JSON")


# ============================================================================ controllers

CONTROLLERS: dict[str, tuple[str, str]] = {
    # label -> (expect, the file's text); {tau} is tau's body
    "zeros": (OK, "def make(robot, **gains):\n    return lambda t, q, v: np.zeros(robot.nv)\n"),
    "constant": (OK, "def make(robot, **gains):\n    return lambda t, q, v: np.array([0.1, 0.0])\n"),
    "actuated only": (OK, "def make(robot, **gains):\n    return lambda t, q, v: [0.05]\n"),
    "pd on a copy": (
        OK,
        "def make(robot, **gains):\n    def tau(t, q, v):\n        q = q.copy()\n"
        "        q[1] = 0.0\n        return np.array([-2.0 * q[0] - 0.1 * v[0], 0.0])\n"
        "    return tau\n",
    ),
    "prints": (
        OK,
        "print('hello')\ndef make(robot, **gains):\n    print('made')\n    return lambda t, q, v: np.zeros(2)\n",
    ),
    "os._exit at import": (REFUSE, "os._exit(0)\n"),
    "os._exit in make": (REFUSE, "def make(robot, **gains):\n    os._exit(0)\n"),
    "os._exit in tau": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: os._exit(0)\n"),
    "os._exit later": (
        REFUSE,
        "def make(robot, **gains):\n    def tau(t, q, v):\n        if t > 0.02:\n"
        "            os._exit(0)\n        return np.zeros(2)\n    return tau\n",
    ),
    "sys.exit in tau": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: sys.exit(0)\n"),
    "sys.exit at import": (REFUSE, "sys.exit(0)\n"),
    "loop in tau": (
        REFUSE,
        "def make(robot, **gains):\n    def tau(t, q, v):\n        while True:\n            pass\n    return tau\n",
    ),
    "loop catching everything": (
        REFUSE,
        "def make(robot, **gains):\n    def tau(t, q, v):\n        while True:\n"
        "            try:\n                pass\n            except Exception:\n"
        "                pass\n    return tau\n",
    ),
    "raises": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: 1 / 0\n"),
    "make raises": (REFUSE, "def make(robot, **gains):\n    raise RuntimeError('no')\n"),
    "no make": (REFUSE, "x = 1\n"),
    "make not callable result": (REFUSE, "def make(robot, **gains):\n    return 3\n"),
    "syntax error": (REFUSE, "def make(:\n"),
    "writes q": (
        REFUSE,
        "def make(robot, **gains):\n    def tau(t, q, v):\n        q[1] = 0.0\n"
        "        return np.zeros(2)\n    return tau\n",
    ),
    "writes v": (
        REFUSE,
        "def make(robot, **gains):\n    def tau(t, q, v):\n        v *= 2\n"
        "        return np.zeros(2)\n    return tau\n",
    ),
    "copyto q": (
        REFUSE,
        "def make(robot, **gains):\n    def tau(t, q, v):\n        np.copyto(q, 0.0)\n"
        "        return np.zeros(2)\n    return tau\n",
    ),
    "returns scalar": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: 0.0\n"),
    "returns 3": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: np.zeros(3)\n"),
    "returns 2-D": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: np.zeros((2, 1))\n"),
    "returns string": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: 'abc'\n"),
    "returns strings": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: ['1', '2']\n"),
    "returns None": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: None\n"),
    "returns dict": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: {'a': 1}\n"),
    "returns ragged": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: [1.0, [2.0, 3.0]]\n"),
    "returns complex": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: np.zeros(2) * (1 + 1j)\n"),
    "returns object": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: np.zeros(2).astype(object)\n"),
    "returns 2**70": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: [2**70, 0]\n"),
    "returns nan": (REFUSE, "def make(robot, **gains):\n    return lambda t, q, v: np.array([np.nan, 0.0])\n"),
    "returns inf later": (
        REFUSE,
        "def make(robot, **gains):\n    return lambda t, q, v: np.array([np.inf if t > 0.01 else 0.0, 0.0])\n",
    ),
}
CONTROLLER_LABELS = list(CONTROLLERS)
SLOW = {"loop in tau", "loop catching everything"}


def _controller(pick: Any, fixtures: dict[str, bytes]) -> dict[str, Any]:
    label = pick.choice(CONTROLLER_LABELS)
    if label in SLOW and pick.integer(0, 3):  # a loop costs the 10 s limit: drawn a quarter as often
        label = pick.choice([k for k in CONTROLLER_LABELS if k not in SLOW])
    expect, body = CONTROLLERS[label]
    text = "import os\nimport sys\n\nimport numpy as np\n\n" + body
    files = {"model.urdf": fixtures["model.urdf"], "ctl.py": text.encode()}
    if pick.integer(0, 2) == 0:
        files["scene.toml"] = (
            b'[model]\nname = "pendubot"\n[control]\nkind = "file"\npath = "ctl.py"\n'
            b'[simulate]\nduration = 0.05\ndt = 0.001\nintegrator = "rk4"\n'
        )
        argv = ["run", "scene.toml", "--no-view", "--out", "out"]
        return _case(f"controller {label} (scene)", label, "run", files, argv, expect=expect, out="out/scene.npz")
    backend = pick.choice([[], [], ["--backend", "aba"]])
    argv = ["simulate", "pendubot", "--controller", "ctl.py", "--duration", "0.05", "--out", "x.npz", *backend]
    return _case(f"controller {label}", label, "simulate", files, argv, expect=expect, out="x.npz")


def _run_findings(out: str, label: str) -> list[str]:
    """A run accepted with a controller: its file holds it, the energy books close, q follows v."""
    from robodyn.errors import RobodynError
    from robodyn.sim.trajectory import Trajectory

    try:
        run = Trajectory.load(out)
    except RobodynError as exc:
        return [f"exit 0 but its trajectory does not load: {exc}"]
    found = []
    if run.status != "ok":
        found.append(f"exit 0 with a run of status {run.status}")
    if run.max_ledger_residual > 1e-6:  # rk4 at dt = 1 ms closes the books to ~1e-10 J over 0.05 s
        found.append(f"ledger residual {run.max_ledger_residual:.2e} J")
    dt = np.diff(run.t)[:, None]
    slope = np.abs(np.diff(run.q, axis=0) - 0.5 * dt * (run.v[1:] + run.v[:-1])).max()
    if slope > 1e-4:  # the trapezoid of v over one step matches the step of q to O(dt^3)
        found.append(f"q does not follow v: {slope:.2e} rad off over a step")
    if label == "constant" and not np.allclose(run.tau[:, 0], 0.1):
        found.append("the constant controller's torque is not in the file")
    return found


# ============================================================================ gains

GAINS: list[tuple[str, str]] = [
    (OK, "{}"), (OK, '{"R": 0.1}'), (OK, '{"Q": [10, 10, 1, 1]}'), (OK, '{"Q": 5, "R": [0.5]}'),
    (REFUSE, '{"Q": null}'), (REFUSE, '{"Q": true}'), (REFUSE, '{"R": false}'), (REFUSE, '{"R": "0.1"}'),
    (REFUSE, '{"Q": []}'), (REFUSE, '{"Q": [[1]]}'), (REFUSE, '{"Q": {"a": 1}}'), (REFUSE, '{"R": NaN}'),
    (REFUSE, '{"R": Infinity}'), (REFUSE, '{"R": 1e400}'), (REFUSE, '{"R": -1}'), (REFUSE, '{"R": 0}'),
    (REFUSE, '{"Q": [1, 2, 3]}'), (REFUSE, '{"nope": 1}'), (REFUSE, '{"Q": [[[[1]]]]}'), (REFUSE, "[1, 2]"),
    (REFUSE, '{"Q": [true, 1, 1, 1]}'), (REFUSE, '{"K": [null, 0, 0, 0]}'), (REFUSE, '{"q_eq": [1e308, 0]}'),
    (REFUSE, '{"u_eq": "x"}'), (REFUSE, '{"R": ' + "[" * 3000 + "]" * 3000 + "}"), (REFUSE, "null"),
]  # fmt: skip


def _gains(pick: Any, fixtures: dict[str, bytes]) -> dict[str, Any]:
    expect, text = pick.choice(GAINS)
    files = {"model.urdf": fixtures["model.urdf"]}
    gains = text
    if pick.integer(0, 2) == 0:
        files["g.json"] = text.encode()
        gains = "g.json"
    argv = ["simulate", "pendubot", "--controller", "lqr", "--gains", gains, "--duration", "0.05", "--out", "x.npz"]
    return _case("gains " + ("valid" if expect == OK else "hostile"), text[:40], "simulate", files, argv,
                 expect=expect, out="x.npz")  # fmt: skip


# ============================================================================ formulas

FORMULA = (ROOT / "examples" / "formulas" / "pendubot_mine.py").read_text(encoding="utf-8")
M_RETURN = "    return np.array([[t1 + t2 + 2 * t3 * c2, t2 + t3 * c2], [t2 + t3 * c2, t2]])"
FORMULA_OPS: dict[str, tuple[str, str]] = {
    # label -> (expect, the new last line of mass_matrix)
    "valid": (OK, M_RETURN),
    "valid list": (OK, "    return [[t1 + t2 + 2 * t3 * c2, t2 + t3 * c2], [t2 + t3 * c2, t2]]"),
    "complex": (REFUSE, M_RETURN.replace("return ", "return (1 + 1e-3j) * ")),
    "complex zero imaginary": (REFUSE, M_RETURN.replace("return ", "return (1 + 0j) * ")),
    "object": (REFUSE, M_RETURN + ".astype(object)"),
    "2**70": (REFUSE, "    return [[2**70, 0], [0, 1]]"),
    "int overflow": (REFUSE, "    return np.array([[10**400, 0], [0, 1]])"),
    "string": (REFUSE, "    return [['1', '0'], ['0', '1']]"),
    "None": (REFUSE, "    return None"),
    "shape 3x3": (REFUSE, "    return np.eye(3)"),
    "scalar": (REFUSE, "    return 1.0"),
    "ragged": (REFUSE, "    return [[1.0, 0.0], [0.0]]"),
    "nan": (REFUSE, M_RETURN + " * np.nan"),
    "raises": (REFUSE, "    return 1 / 0"),
    "raises KeyError": (REFUSE, "    return p['nope']"),
    "sys.exit": (REFUSE, "    sys.exit(0)"),
    "os._exit": (REFUSE, "    os._exit(0)"),
    "loop": (REFUSE, "    while True:\n        pass"),
    "print": (OK, "    print('M')\n" + M_RETURN),
    "wrong physics": ("mismatch", M_RETURN.replace("t2]])", "2 * t2]])")),
    "dict": (REFUSE, "    return {'a': 1}"),
    "generator": (REFUSE, "    return (x for x in range(4))"),
}
FORMULA_AT_IMPORT = {"os._exit at import": "os._exit(0)", "loop at import": "while True:\n    pass",
                     "sys.exit at import": "sys.exit(3)", "raise at import": "raise ValueError('x')",
                     "KeyboardInterrupt at import": "raise KeyboardInterrupt",
                     "BaseException at import": "class B(BaseException):\n    pass\nraise B('x')",
                     "multi-line error at import": "raise ValueError('line one\\nline two')",
                     "print flood at import": "print('x' * 100000)\nsys.stderr.write('y\\n' * 1000)",
                     "KIND missing": "del KIND", "KIND number": "KIND = 3", "KIND unknown": "KIND = 'nope'",
                     "KIND constrained": "KIND = 'constrained'", "gravity missing": "del gravity",
                     "mass_matrix not callable": "mass_matrix = 3",
                     "wrong arity": "def mass_matrix(q):\n    return np.eye(2)",
                     "recursion": "def mass_matrix(q, p):\n    return mass_matrix(q, p)",
                     "huge array": "def mass_matrix(q, p):\n    return np.zeros((30000, 30000))",
                     "raises KeyboardInterrupt": "def mass_matrix(q, p):\n    raise KeyboardInterrupt",
                     "raises BaseException": "def gravity(q, p):\n    raise GeneratorExit",
                     "multi-line error": "def gravity(q, p):\n    raise ValueError('one\\ntwo\\nthree')",
                     "returns matrix": "def gravity(q, p):\n    return np.matrix([[1.0, 2.0]])",
                     "potential array": "def potential_energy(q, p):\n    return np.ones(3)",
                     "potential complex": "def potential_energy(q, p):\n    return 1j",
                     "gravity complex": "def gravity(q, p):\n    return np.array([1 + 1j, 0])",
                     "coriolis object": "def coriolis_matrix(q, v, p):\n    return np.array([[None, 0], [0, 0]])",
                     "coriolis bool": "def coriolis_matrix(q, v, p):\n    return np.zeros((2, 2), dtype=bool)",
                     "__array__ raises": "class A:\n    def __array__(self, *a, **k):\n        raise ValueError('no')"
                                         "\ndef gravity(q, p):\n    return A()",
                     "COORDINATES motor": "COORDINATES = 'motor'", "COORDINATES bogus": "COORDINATES = 3",
                     "writes q": "_m = mass_matrix\ndef mass_matrix(q, p):\n    q[0] = 1e9\n    return _m(q, p)",
                     "writes p": "_g = gravity\ndef gravity(q, p):\n    p['g'] = 0.0\n    return _g(q, p)"}  # fmt: skip
FORMULA_BYTES = {"not UTF-8": b"KIND = '\xff\xfe'\n", "null bytes": b"KIND = 'pendubot'\x00\n", "empty": b""}


LINKAGE = ROOT / "examples" / "textbook" / "linkage"
CONSTRAINED_OPS: dict[str, tuple[str, str]] = {
    # label -> (expect, lines appended to the linkage's reduced_formula.py)
    "valid": (OK, ""),
    "parameters list": (REFUSE, "def parameters(scene):\n    return [1, 2]"),
    "parameters complex": (REFUSE, "_p = parameters\ndef parameters(scene):\n    return {**_p(scene), 'l': 1j}"),
    "parameters nan": (REFUSE, "_p = parameters\ndef parameters(scene):\n    return {**_p(scene), 'l': float('nan')}"),
    "parameters bool": (REFUSE, "_p = parameters\ndef parameters(scene):\n    return {**_p(scene), 'l': True}"),
    "parameters raises": (REFUSE, "def parameters(scene):\n    raise ValueError('a\\nb')"),
    "parameters os._exit": (REFUSE, "def parameters(scene):\n    os._exit(0)"),
    "parameters key not str": (REFUSE, "_p = parameters\ndef parameters(scene):\n    return {**_p(scene), 3: 1.0}"),
    "on_the_loop None": (REFUSE, "def on_the_loop(q, v, p):\n    return None"),
    "on_the_loop complex": (REFUSE, "_o = on_the_loop\ndef on_the_loop(q, v, p):\n    a, b = _o(q, v, p)\n"
                                    "    a['joint_a'] = 1j\n    return a, b"),
    "on_the_loop strings": (REFUSE, "_o = on_the_loop\ndef on_the_loop(q, v, p):\n    a, b = _o(q, v, p)\n"
                                    "    a['joint_a'] = 'x'\n    return a, b"),
    "on_the_loop array": (REFUSE, "_o = on_the_loop\ndef on_the_loop(q, v, p):\n    a, b = _o(q, v, p)\n"
                                  "    a['joint_a'] = np.ones(3)\n    return a, b"),
    "on_the_loop unknown joint": (REFUSE, "_o = on_the_loop\ndef on_the_loop(q, v, p):\n    a, b = _o(q, v, p)\n"
                                          "    a['nope'] = 0.0\n    b['nope'] = 0.0\n    return a, b"),
    "on_the_loop missing joint": (REFUSE, "_o = on_the_loop\ndef on_the_loop(q, v, p):\n    a, b = _o(q, v, p)\n"
                                          "    del a['guide'], b['guide']\n    return a, b"),
    "on_the_loop off the loop": ("mismatch", "_o = on_the_loop\ndef on_the_loop(q, v, p):\n    a, b = _o(q, v, p)\n"
                                             "    a['guide'] += 0.1\n    return a, b"),
    "on_the_loop loops": (REFUSE, "def on_the_loop(q, v, p):\n    while True:\n        pass"),
    "INDEPENDENT unknown": (REFUSE, "INDEPENDENT = ('nope',)"),
    "INDEPENDENT two": (REFUSE, "INDEPENDENT = ('joint_a', 'joint_b')"),
    "INDEPENDENT string": (REFUSE, "INDEPENDENT = 'joint_a'"),
    "INDEPENDENT numbers": (REFUSE, "INDEPENDENT = (1,)"),
    "mass complex": (REFUSE, "_m = mass_matrix\ndef mass_matrix(q, p):\n    return _m(q, p) * (1 + 1e-3j)"),
    "mass object": (REFUSE, "_m = mass_matrix\ndef mass_matrix(q, p):\n    return _m(q, p).astype(object)"),
    "potential complex": (REFUSE, "def potential_energy(q, p):\n    return 1j"),
}  # fmt: skip


def _constrained(pick: Any, fixtures: dict[str, bytes]) -> dict[str, Any]:
    label = pick.choice(list(CONSTRAINED_OPS))
    expect, tail = CONSTRAINED_OPS[label]
    files = {name: (LINKAGE / name).read_bytes() for name in ("linkage.toml", "linkage.urdf", "closed_form.py")}
    files["reduced_formula.py"] = (
        "import os\n" + (LINKAGE / "reduced_formula.py").read_text(encoding="utf-8") + "\n" + tail + "\n"
    ).encode()
    argv = ["check", "linkage.toml", "--formula", "reduced_formula.py", "--samples", "2", "--formula-timeout", "5"]
    if pick.integer(0, 3) == 0:
        argv.append("--json")
    return _case(f"formula constrained {label}", label, "check", files, argv, expect=expect)


def _formula(pick: Any, fixtures: dict[str, bytes]) -> dict[str, Any]:
    if pick.integer(0, 3) == 0:
        return _constrained(pick, fixtures)
    head = "import os\nimport sys\n"
    data = None
    choice = pick.integer(0, 9)
    if choice < 4:
        label = pick.choice(list(FORMULA_AT_IMPORT))
        text, expect = head + FORMULA + "\n" + FORMULA_AT_IMPORT[label] + "\n", REFUSE
        if label in ("print flood at import", "writes q", "writes p"):
            expect = OK if label == "print flood at import" else "any"
    elif choice == 4:
        label = pick.choice(list(FORMULA_BYTES))
        text, expect, data = "", REFUSE, FORMULA_BYTES[label]
    else:
        label = pick.choice(list(FORMULA_OPS))
        expect, line = FORMULA_OPS[label]
        text = head + FORMULA.replace(M_RETURN, line)
    files = {"model.urdf": fixtures["model.urdf"], "f.py": data if data is not None else text.encode()}
    route = pick.integer(0, 5)
    if route == 0:  # a scene's [check] formula
        files["scene.toml"] = (
            b'[model]\nname = "pendubot"\n[check]\nformula = "f.py"\nsamples = 2\nformula_timeout = 5\n'
        )
        argv = ["run", "scene.toml", "--no-view", "--out", "out"]
        return _case(f"formula {label} (scene)", label, "check", files, argv, expect=expect)  # exits as check
    models = ["pendubot", "model.urdf"] if route == 1 else ["pendubot"]
    argv = ["check", *models, "--formula", "f.py", "--samples", "2", "--formula-timeout", "5"]
    if route == 2:  # numbers that are not the model's: a right formula may mismatch (exit 1)
        files["p.json"] = fixtures["p.json"]
        argv += ["--params", "p.json"]
        expect = "any" if expect in (OK, "mismatch") else expect
    if pick.integer(0, 3) == 0:
        argv.append("--json")
    return _case(f"formula {label}", label, "check", files, argv, expect=expect)


# ============================================================================ --json outputs

JSON_COMMANDS = [
    ["simulate", "pendubot", "--v0", "1e100,0", "--dt", "0.1", "--duration", "1", "--json"],
    ["simulate", "pendubot", "--v0", "1e150,1e150", "--duration", "0.05", "--json"],
    ["simulate", "pendubot", "--q0", "1.2,0.9", "--duration", "3", "--dt", "0.1", "--json", "--out", "d.npz"],
    ["simulate", "pendubot", "--torque", "1e300,0", "--no-effort-limits", "--duration", "0.05", "--json"],
    ["simulate", "pendubot", "--integrator", "euler", "--dt", "0.5", "--v0", "100,100", "--duration", "3", "--json"],
    ["simulate", "cart_pole", "--v0", "1e200,0", "--duration", "0.05", "--json"],
    ["simulate", "pendubot", "--duration", "0.05", "--json"],
    ["simulate", "pendubot", "--controller", "list", "--json"],
    ["simulate", "pendubot", "--integrator", "list", "--json"],
    ["info", "pendubot", "--json"],
    ["info", "model.urdf", "--json"],
    ["check", "pendubot", "--samples", "2", "--json"],
    ["check", "cart_pole", "--samples", "2", "--json"],
    ["check", "pendubot", "--samples", "2", "--formula", "bad.py", "--json"],
]
BAD_FORMULA = FORMULA.replace('return p["g"] * np.array', 'return 1e308 * p["g"] * np.array')


def _json_case(pick: Any, fixtures: dict[str, bytes]) -> dict[str, Any]:
    argv = list(pick.choice(JSON_COMMANDS))
    files = {"model.urdf": fixtures["model.urdf"], "bad.py": BAD_FORMULA.encode()}
    return _case(f"json {argv[0]}", " ".join(argv[1:4]), argv[0], files, argv, expect="any", strict_json=True)


# ============================================================================ SRDF

SRDF = """<?xml version="1.0"?>
<robot name="pendubot">
  <passive_joint name="joint2"/>
  <rotor_params>
    <joint name="joint1" mass="1e-6" gear_ratio="10"/>
  </rotor_params>
</robot>
"""
SRDF_NUMBERS = ["nan", "inf", "-inf", "-1", "0", "1e308", "1e-400", "", "abc", "0x10", " 2 ", "1,5", "1e6", "2e-5"]
SRDF_OPS = [
    "valid", "valid no rotor", "mass", "gear_ratio", "passive unknown", "passive both", "passive twice",
    "passive no name", "rotor unknown joint", "rotor no mass", "rotor twice", "robot name other", "truncated",
    "entity", "billion laughs", "utf-16", "byte order mark", "deep nesting", "binary", "empty", "not a robot",
    "huge comment",
]  # fmt: skip


def _srdf(pick: Any, fixtures: dict[str, bytes]) -> dict[str, Any]:
    op = pick.choice(SRDF_OPS)
    text, data, label = SRDF, None, op
    if op == "valid no rotor":
        text = re.sub(r"\s*<rotor_params>.*</rotor_params>", "", SRDF, flags=re.S)
    elif op in ("mass", "gear_ratio"):
        value = pick.choice(SRDF_NUMBERS)
        text = re.sub(rf'{op}="[^"]*"', f'{op}="{value}"', SRDF)
        label = f"{op} {value!r}"
    elif op == "passive unknown":
        text = SRDF.replace('passive_joint name="joint2"', 'passive_joint name="nope"')
    elif op == "passive both":
        text = SRDF.replace("<passive_joint", '<passive_joint name="joint1"/><passive_joint', 1)
    elif op == "passive twice":
        text = SRDF.replace("<passive_joint", '<passive_joint name="joint2"/><passive_joint', 1)
    elif op == "passive no name":
        text = SRDF.replace('passive_joint name="joint2"', "passive_joint")
    elif op == "rotor unknown joint":
        text = SRDF.replace('joint name="joint1" mass', 'joint name="nope" mass')
    elif op == "rotor no mass":
        text = SRDF.replace(' mass="1e-6"', "")
    elif op == "rotor twice":
        text = SRDF.replace("</rotor_params>", '<joint name="joint1" mass="2e-6" gear_ratio="3"/></rotor_params>')
    elif op == "robot name other":
        text = SRDF.replace('robot name="pendubot"', 'robot name="other"')
    elif op == "truncated":
        data = SRDF.encode()[: pick.integer(0, len(SRDF) - 1)]
    elif op == "entity":
        text = SRDF.replace("<robot ", '<!DOCTYPE robot [<!ENTITY m "1e-6">]>\n<robot ').replace('"1e-6"', '"&m;"', 1)
    elif op == "billion laughs":
        ents = '<!ENTITY a "aaaaaaaaaa">' + "".join(
            f'<!ENTITY {c} "{("&" + q + ";") * 10}">' for q, c in zip("abcde", "bcdef", strict=True)
        )
        text = SRDF.replace("<robot ", f"<!DOCTYPE robot [{ents}]>\n<robot ").replace(
            "<passive_joint", "<x a='&f;'/><passive_joint"
        )
    elif op == "utf-16":
        data = SRDF.replace('version="1.0"?>', 'version="1.0" encoding="UTF-16"?>').encode("utf-16")
    elif op == "byte order mark":
        data = b"\xef\xbb\xbf" + SRDF.encode()
    elif op == "deep nesting":
        text = SRDF.replace("</robot>", "<a>" * 5000 + "</a>" * 5000 + "</robot>")
    elif op == "binary":
        data = bytes(range(256))
    elif op == "empty":
        data = b""
    elif op == "not a robot":
        data = b"<html></html>"
    elif op == "huge comment":
        text = SRDF.replace("<robot ", f"<!-- {'c' * 3_000_000} --><robot ")
    files = {"model.urdf": fixtures["model.urdf"], "s.srdf": data if data is not None else text.encode()}
    command = pick.choice(["info", "simulate", "check"])
    argv = {
        "info": ["info", "model.urdf", "--srdf", "s.srdf", "--json"],
        "simulate": ["simulate", "model.urdf", "--srdf", "s.srdf", "--duration", "0.05", "--torque", "0.1"],
        "check": ["check", "model.urdf", "--srdf", "s.srdf", "--samples", "2"],
    }[command]
    expect = OK if op.startswith("valid") else "any"
    return _case(f"srdf {op}", label, command, files, argv, expect=expect, srdf=True, strict_json=command == "info")


def _listed_errors(stdout: Path) -> set[str]:
    """The joints and links that ``info --json`` lists a physics error for (its captured stdout)."""
    try:
        findings = json.loads(Path(stdout).resolve().read_text(encoding="utf-8")).get("findings", [])
    except (OSError, ValueError, AttributeError):
        return set()
    return {str(f.get("where")) for f in findings if isinstance(f, dict) and f.get("severity") == "error"}


def _srdf_findings(listed: set[str] | None = None) -> list[str]:
    """An accepted SRDF: the model's armature is J n^2 and its passive joints those the file says (lxml reading).

    A passive joint the model does not have is skipped at load (``info`` lists it): not a finding.
    ``listed``: for ``info``, which lists physics instead of refusing it, the joints it lists an
    error for (a negative rotor mass accepted and listed is right there).
    """
    from lxml import etree

    import robodyn

    try:
        root = etree.parse("s.srdf", etree.XMLParser(resolve_entities=False, load_dtd=False, no_network=True)).getroot()
    except (etree.XMLSyntaxError, OSError, ValueError) as exc:
        return [f"accepted an SRDF that lxml cannot read: {str(exc)[:80]}"]
    # info never refuses for physics (it lists the findings, exit 0): read the file's numbers as written
    robot = robodyn.load("model.urdf", srdf="s.srdf", check_physics=False)
    found = []
    expected = np.zeros(robot.nv)
    for joint in root.findall("rotor_params/joint"):
        try:
            mass, ratio = float(joint.get("mass")), float(joint.get("gear_ratio"))
        except (TypeError, ValueError):
            return [f"accepted rotor parameters that are not numbers: {dict(joint.attrib)}"]
        if not (math.isfinite(mass) and math.isfinite(ratio)):
            return [f"accepted rotor parameters {dict(joint.attrib)}"]
        if mass < 0 and (listed is None or joint.get("name") not in listed):
            return [f"accepted a negative rotor mass without listing it: {dict(joint.attrib)}"]
        name = joint.get("name")
        if not math.isfinite(mass * ratio * ratio):
            return [f"accepted rotor parameters whose J n^2 overflows: {dict(joint.attrib)}"]
        if name in robot.joint_names:
            expected[robot.joint_names.index(name)] = mass * ratio * ratio
    armature = np.asarray(robot.model.armature, dtype=np.float64)
    if not np.allclose(armature, expected, rtol=1e-12, atol=0):  # one product: exact up to rounding
        found.append(f"armature {armature.tolist()} where the file says {expected.tolist()}")
    passive = sorted({str(j.get("name")) for j in root.findall("passive_joint")} & set(robot.joint_names))
    actuated = [name for name, a in zip(robot.joint_names, robot.actuated, strict=True) if not a]
    if sorted(actuated) != passive:
        found.append(f"passive joints {sorted(actuated)} where the file says {passive}")
    return found


# ============================================================================ running


def execute(case: Any) -> tuple[int, list[str]]:
    """Run ``case`` here (the forked child, in the case's folder): its exit code and what is wrong."""
    from robodyn.cli import main

    try:
        code = main(list(case.argv))
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 2
    sys.stdout.flush()
    oracle = case.oracle or {}
    expect = oracle.get("expect")
    wrong: list[str] = []
    if expect == REFUSE and code == 0:
        wrong.append("exit 0 where a refusal was due")
    if expect == OK and code != 0:
        wrong.append(f"a valid file refused (exit {code})")
    if expect == "mismatch" and code not in (1, 2):
        wrong.append(f"a wrong formula passed (exit {code})")
    if code == 0 and case.command == "view":
        wrong += _page_findings()
    if code == 0 and oracle.get("out") and expect == OK:
        wrong += _run_findings(oracle["out"], case.label)
    if oracle.get("srdf") and code == 0:
        wrong += _srdf_findings(listed=_listed_errors(Path("/dev/fd/1")) if case.command == "info" else None)
    if oracle.get("strict_json") and code in (0, 1, 3):
        wrong += _json_findings(Path("/dev/fd/1"))
    return code, wrong


def _json_findings(stdout: Path) -> list[str]:
    """stdout (the case's captured file) parsed by a strict JSON parser."""
    try:
        text = Path(stdout).resolve().read_text(encoding="utf-8")
    except OSError as exc:
        return [f"cannot read the output: {exc}"]
    try:
        json.loads(text, parse_constant=_refuse_constant)
    except ValueError as exc:
        return [f"--json printed no strict JSON: {str(exc)[:80]}"]
    return []


def families(fuzz: Any) -> list[Any]:
    """This module's families for ``benchmarks/fuzz.py`` (given that module): one per kind of :data:`KINDS`.

    Their cases run through :func:`execute` (fuzz.py's ``_execute`` hands them over by kind).
    """

    def maker(kind: str) -> Any:
        def make_case(index: int, pick: Any, inputs: Any) -> Any:
            return fuzz.Case(index=index, kind=kind, **make(kind, index, pick, inputs.fixtures))

        return make_case

    return [fuzz.Family(kind, weight, maker(kind)) for kind, weight in KINDS.items()]
