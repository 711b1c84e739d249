"""The explain corpus: robots, their correct formula files and planted single mistakes, each with its true term.

Layout, one folder per robot::

    benchmarks/explain_corpus/<robot>/robot.urdf    the robot, written by hand (or [robot] model = "ur5")
    benchmarks/explain_corpus/<robot>/correct.py    a correct KIND = "any" formula file (robodyn check: PASS)
    benchmarks/explain_corpus/<robot>/cases.toml    [robot] and the planted mistakes, [[case]]

A case is a text substitution ``old`` -> ``new`` of the correct file that must apply exactly once, the
kind of ``slip``, and what a right diagnosis says:

* ``[case.truth]``: every entry of the difference ``planted - correct`` (which is ``planted - Pinocchio``)
  as a sympy expression in the file's parameter names, its coordinate names (``NAMES``) and their
  velocities (``<name>_dot``), e.g. ``"M[0,1]" = "m2*(lc1 - l1)*cos(phi1)"``. Keys ``M[i,j]``, ``C[i,j]``,
  ``G[i]``, ``V``; an ``M[i,j]`` with i < j stands for ``M[j,i]`` too unless that is listed. Every entry
  not listed is zero.
* ``[case.hint]``: for a convention slip (the zero or the sign of an angle, the order of the joints,
  gravity's sign, a transposed C), the one-line hint a right diagnosis gives: ``words`` it must
  mention (the joint, ``COORDINATES``...), ``fix`` in words and, for a COORDINATES slip,
  ``coordinates = [sign, offset]`` of ``joint`` that makes the planted file agree.

This module checks that the corpus cannot lie, with NumPy and sympy only (no Pinocchio): each edit
applies exactly once, and at seeded random parameter values and states the planted file minus the
correct one equals the truth, entry by entry (for a COORDINATES slip: the planted file minus the
correct one carried into the planted coordinates, and the hint's fix makes it vanish)::

    python benchmarks/explain_corpus/verify.py
    python benchmarks/explain_corpus/verify.py --plant crane-dropped-rope-m12 > planted.py   # one case's file
"""

from __future__ import annotations

import math
import re
import sys
import types
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

CORPUS = Path(__file__).resolve().parent
DRAWS = 24  # random (parameters, state) draws per case: a wrong truth is off at almost every one
AGREE_RTOL = 1e-9  # planted - correct vs the truth: both are the same arithmetic up to round-off (~1e-15)
VISIBLE = 1e-6  # a planted slip must change some entry by more than this fraction of its scale
FUNCTIONS = {"sin", "cos", "tan", "sqrt", "exp", "pi", "Abs"}


class CorpusError(Exception):
    """A case of the corpus that does not hold (an edit that does not apply once, a truth that is not)."""


@dataclass(frozen=True)
class Case:
    """One planted mistake: the edit, the kind of slip, and the true term or hint."""

    id: str
    robot: str
    slip: str
    old: str
    new: str
    truth: Mapping[str, str] = field(default_factory=dict)
    hint: Mapping[str, Any] | None = None
    note: str = ""

    @property
    def convention(self) -> bool:
        """A slip whose right diagnosis is a one-line hint (it may have a true term as well)."""
        return self.hint is not None


@dataclass(frozen=True)
class Robot:
    """A corpus robot: its URDF, its correct formula file and its cases."""

    name: str
    folder: Path
    urdf: Path  # the URDF file; a robot of robodyn's model sources is named by ``model`` instead
    formula: Path
    requires: tuple[str, ...]  # robodyn features the correct file needs that today's robodyn may lack
    note: str
    cases: tuple[Case, ...]
    equivalent: Path | None = None  # a correct file of the same robot in other coordinates: must agree
    model_name: str = ""  # a robodyn model name (``ur5``) in place of the URDF file

    @property
    def model(self) -> str:
        """What ``robodyn check`` is given: the URDF's path, or the model's name."""
        return self.model_name or str(self.urdf)

    def correct_text(self) -> str:
        """The correct formula file's text."""
        return self.formula.read_text(encoding="utf-8")


def _toml(path: Path) -> dict[str, Any]:
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib
    with path.open("rb") as f:
        return tomllib.load(f)


def load_corpus(folder: Path = CORPUS) -> list[Robot]:
    """Every robot of the corpus (folders holding a ``cases.toml``), by name."""
    robots = []
    for manifest in sorted(folder.glob("*/cases.toml")):
        data = _toml(manifest)
        meta = data.get("robot", {})
        name = manifest.parent.name
        cases = tuple(
            Case(
                id=str(c["id"]),
                robot=name,
                slip=str(c["slip"]),
                old=str(c["old"]),
                new=str(c["new"]),
                truth={str(k): str(v) for k, v in c.get("truth", {}).items()},
                hint=c.get("hint"),
                note=str(c.get("note", "")),
            )
            for c in data.get("case", [])
        )
        robots.append(
            Robot(
                name=name,
                folder=manifest.parent,
                urdf=manifest.parent / meta.get("urdf", "robot.urdf"),
                formula=manifest.parent / meta.get("formula", "correct.py"),
                requires=tuple(meta.get("requires", ())),
                note=str(meta.get("note", "")),
                cases=cases,
                equivalent=manifest.parent / meta["equivalent"] if "equivalent" in meta else None,
                model_name=str(meta.get("model", "")),
            )
        )
    return robots


def planted_text(robot: Robot, case: Case) -> str:
    """The correct file with the case's edit applied; CorpusError unless ``old`` occurs exactly once."""
    text = robot.correct_text()
    count = text.count(case.old)
    if count != 1:
        raise CorpusError(f"{case.id}: the edit's old text occurs {count} times in {robot.formula.name}; expected once")
    return text.replace(case.old, case.new)


def load_module(text: str, name: str) -> types.ModuleType:
    """A formula file's text run as a fresh module (the corpus's own files only)."""
    module = types.ModuleType(name)
    exec(compile(text, f"<{name}>", "exec"), module.__dict__)  # the corpus's own files
    return module


def coordinate_names(module: types.ModuleType) -> tuple[str, ...]:
    """The file's ``NAMES``, else q1, q2, ...; velocities are ``<name>_dot``."""
    names = getattr(module, "NAMES", None)
    return tuple(names) if names else tuple(f"q{i + 1}" for i in range(len(module.JOINTS)))


class RandomParameters(dict):  # type: ignore[type-arg]
    """A parameter dict that draws a value in [0.2, 1.5) for any name the first time it is read."""

    def __init__(self, rng: np.random.Generator) -> None:
        super().__init__()
        self.rng = rng

    def __missing__(self, key: str) -> float:
        value = float(self.rng.uniform(0.2, 1.5))
        self[key] = value
        return value


# ------------------------------------------------------------------------------------ coordinates
def _affine(module: types.ModuleType, order: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """(T, b) with q_formula = T q_urdf + b, q_urdf over the joints ``order``."""
    joints = list(module.JOINTS)
    n = len(joints)
    perm = np.zeros((n, n))
    for i, joint in enumerate(joints):
        perm[i, order.index(joint)] = 1.0
    value = getattr(module, "COORDINATES", None)
    offsets = np.asarray(getattr(module, "OFFSETS", np.zeros(n)), dtype=float)
    if value is None:
        return perm, np.zeros(n)
    if isinstance(value, Mapping):
        signs = np.array([float(value.get(j, (1.0, 0.0))[0]) for j in joints])
        shift = np.array([float(value.get(j, (1.0, 0.0))[1]) for j in joints])
        return np.diag(signs) @ perm, shift
    return np.asarray(value, dtype=float) @ perm, offsets


def coordinate_map(correct: types.ModuleType, planted: types.ModuleType) -> tuple[np.ndarray, np.ndarray]:
    """(A, c) with q_correct = A q_planted + c: where the planted file's coordinates put the correct file's."""
    order = list(correct.JOINTS)
    Tc, bc = _affine(correct, order)
    Tp, bp = _affine(planted, order)
    A = Tc @ np.linalg.inv(Tp)
    return A, bc - A @ bp


def evaluate(module: types.ModuleType, p: Mapping[str, float], q: np.ndarray, v: np.ndarray) -> dict[str, np.ndarray]:
    """M, C, G (and V when the file has it) of a formula file at one state, as arrays."""
    out = {
        "M": np.asarray(module.mass_matrix(q, p), dtype=float),
        "C": np.asarray(module.coriolis_matrix(q, v, p), dtype=float),
        "G": np.asarray(module.gravity(q, p), dtype=float),
    }
    if callable(getattr(module, "potential_energy", None)):
        out["V"] = np.asarray(module.potential_energy(q, p), dtype=float)
    return out


def difference(
    correct: types.ModuleType, planted: types.ModuleType, p: Mapping[str, float], q: np.ndarray, v: np.ndarray
) -> dict[str, np.ndarray]:
    """planted - Pinocchio at the planted file's state (q, v): the correct file carried into its coordinates."""
    A, c = coordinate_map(correct, planted)
    ref = evaluate(correct, p, A @ q + c, A @ v)
    mine = evaluate(planted, p, q, v)
    carried = {"M": A.T @ ref["M"] @ A, "C": A.T @ ref["C"] @ A, "G": A.T @ ref["G"]}
    if "V" in ref and "V" in mine:
        carried["V"] = ref["V"]
    return {k: mine[k] - carried[k] for k in carried}


# ------------------------------------------------------------------------------------ truth
_IDENT = re.compile(r"[A-Za-z_]\w*")


def expression(text: str) -> Any:
    """A truth (or a printed name) as a sympy expression, every identifier but the functions a Symbol."""
    import sympy
    from sympy.parsing.sympy_parser import parse_expr

    local = {n: sympy.Symbol(n) for n in set(_IDENT.findall(text)) - FUNCTIONS}
    return parse_expr(text, local_dict=local)


def numeric(text: str) -> Callable[[Mapping[str, float]], float]:
    """``text`` as a function of a name -> value mapping (a RandomParameters draws what is missing)."""
    import sympy

    expr = expression(text)
    symbols = sorted(expr.free_symbols, key=lambda s: s.name)
    fn = sympy.lambdify(symbols, expr, modules="numpy")
    return lambda env: float(fn(*(env[s.name] for s in symbols)))


def label_key(label: str) -> tuple[str, tuple[int, ...]]:
    """``"M[0,1]"`` -> ("M", (0, 1)); ``"G[2]"`` -> ("G", (2,)); ``"V"`` -> ("V", ())."""
    match = re.fullmatch(r"([MCGV])(?:\[(\d+)(?:,\s*(\d+))?\])?", label.strip())
    if match is None:
        raise CorpusError(f"truth key {label!r}; expected M[i,j], C[i,j], G[i] or V")
    idx = tuple(int(x) for x in match.groups()[1:] if x is not None)
    return match.group(1), idx


def truth_entries(case: Case) -> dict[tuple[str, tuple[int, ...]], str]:
    """The truth per entry, an M[i,j] with i < j mirrored to M[j,i] unless that is listed."""
    out = {label_key(k): v for k, v in case.truth.items()}
    for (key, idx), text in list(out.items()):
        if key == "M" and len(idx) == 2 and idx[0] < idx[1] and (key, idx[::-1]) not in out:
            out[(key, idx[::-1])] = text
    return out


def state_env(names: Sequence[str], p: Mapping[str, float], q: np.ndarray, v: np.ndarray) -> dict[str, float]:
    """Parameters, coordinates by name and velocities as ``<name>_dot`` (and q1.., v1.. as aliases)."""
    env = p if isinstance(p, RandomParameters) else RandomParameters(np.random.default_rng(0))
    if env is not p:
        env.update(p)
    for i, name in enumerate(names):
        env[name] = float(q[i])
        env[f"{name}_dot"] = float(v[i])
    return env


def draw_state(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A random state: q in [-pi, pi), v in [-2, 2)."""
    return rng.uniform(-math.pi, math.pi, n), rng.uniform(-2.0, 2.0, n)


def verify_case(robot: Robot, case: Case, *, draws: int = DRAWS, seed: int = 0) -> None:
    """Raise CorpusError unless the case's edit applies once and its truth (and hint fix) is the difference."""
    correct = load_module(robot.correct_text(), f"{robot.name}_correct")
    planted = load_module(planted_text(robot, case), f"{case.id}_planted")
    names = coordinate_names(correct)
    truths = {k: numeric(v) for k, v in truth_entries(case).items()}
    rng = np.random.default_rng(seed)
    largest = 0.0
    for _ in range(draws):
        p = RandomParameters(rng)
        q, v = draw_state(rng, len(names))
        diff = difference(correct, planted, p, q, v)
        env = state_env(names, p, q, v)
        scale = max(float(np.max(np.abs(x))) for x in evaluate(correct, p, q, v).values())
        for key, d in diff.items():
            for idx in np.ndindex(d.shape):
                largest = max(largest, abs(d[idx]) / (1.0 + scale))
                if case.hint is not None and not case.truth:  # a convention slip stated by its hint alone
                    continue
                want = truths[(key, idx)](env) if (key, idx) in truths else 0.0
                if abs(d[idx] - want) > AGREE_RTOL * (1.0 + scale):
                    label = key + (f"[{','.join(map(str, idx))}]" if idx else "")
                    raise CorpusError(
                        f"{case.id}: {label}: planted - correct = {d[idx]:.6g}, the truth says {want:.6g} "
                        f"(q = {np.round(q, 4).tolist()})"
                    )
        for key, _ in truths:
            if key not in diff:
                raise CorpusError(f"{case.id}: the truth names {key}, which the file does not define")
    if largest <= VISIBLE:
        raise CorpusError(f"{case.id}: the planted edit changes no entry (a slip robodyn cannot see)")
    if case.hint is not None:
        _verify_fix(case, correct, planted, names, rng)


HINT_CHECKS = ("coordinates", "joint_order", "gravity_sign", "transpose_c")


def _fixed(case: Case, planted: types.ModuleType) -> types.ModuleType:
    """The planted module with the hint's fix applied (``hint.check`` says which)."""
    assert case.hint is not None
    check = case.hint.get("check")
    if check == "coordinates":
        fixed = dict(getattr(planted, "COORDINATES", None) or {})
        fixed[case.hint["joint"]] = tuple(float(x) for x in case.hint["coordinates"])
        planted.COORDINATES = fixed
    elif check == "joint_order":
        a, b = case.hint["joints"]
        joints = list(planted.JOINTS)
        i, j = joints.index(a), joints.index(b)
        joints[i], joints[j] = joints[j], joints[i]
        planted.JOINTS = joints
    elif check == "gravity_sign":
        wrong_g = planted.gravity
        planted.gravity = lambda q, p: -np.asarray(wrong_g(q, p))
    elif check == "transpose_c":
        wrong_c = planted.coriolis_matrix
        planted.coriolis_matrix = lambda q, v, p: np.asarray(wrong_c(q, v, p)).T
    else:
        raise CorpusError(f"{case.id}: hint.check = {check!r}; expected one of {', '.join(HINT_CHECKS)}")
    return planted


def _verify_fix(case: Case, correct: Any, planted: Any, names: Sequence[str], rng: Any) -> None:
    """The hint names what it must (``words``) and its fix makes the planted file agree with Pinocchio."""
    assert case.hint is not None
    if not case.hint.get("words"):
        raise CorpusError(f"{case.id}: the hint lists no words a right hint must mention")
    fixed = _fixed(case, planted)
    for _ in range(4):
        p = RandomParameters(rng)
        q, v = draw_state(rng, len(names))
        for key, d in difference(correct, fixed, p, q, v).items():
            if np.max(np.abs(d)) > 1e-9 * (1.0 + float(np.max(np.abs(evaluate(correct, p, q, v)[key])))):
                raise CorpusError(f"{case.id}: the hint's fix ({case.hint.get('fix', '')}) leaves {key} wrong")


def verify_equivalent(robot: Robot, *, draws: int = DRAWS, seed: int = 0) -> None:
    """Raise CorpusError unless the correct file agrees with ``equivalent`` through the two files' COORDINATES.

    The proof of a correct file that the robodyn under test cannot check yet (a matrix COORDINATES):
    the same robot's passing file, carried into its coordinates.
    """
    if robot.equivalent is None:
        return
    mine = load_module(robot.correct_text(), f"{robot.name}_correct")
    other = load_module(robot.equivalent.read_text(encoding="utf-8"), f"{robot.name}_equivalent")
    rng = np.random.default_rng(seed)
    for _ in range(draws):
        p = RandomParameters(rng)
        q, v = draw_state(rng, len(mine.JOINTS))
        scale = max(float(np.max(np.abs(x))) for x in evaluate(mine, p, q, v).values())
        for key, d in difference(other, mine, p, q, v).items():
            if np.max(np.abs(d)) > AGREE_RTOL * (1.0 + scale):
                other_name = f"{robot.equivalent.resolve().parent.name}/{robot.equivalent.name}"
                raise CorpusError(f"{robot.name}: correct.py and {other_name} disagree on {key}")


def main(argv: Sequence[str] | None = None) -> int:
    """Verify every case; print one line per problem and a count. Exit 0: the corpus holds; 1: it does not.

    ``--plant ID`` prints that case's planted file instead (exit 2 naming the ids when there is none).
    """
    import argparse

    parser = argparse.ArgumentParser(description="Verify the explain corpus, or print one planted file.")
    parser.add_argument("--plant", metavar="ID", help="print the planted formula file of case ID")
    args = parser.parse_args(argv)
    robots = load_corpus()
    if args.plant is not None:
        found = [(r, c) for r in robots for c in r.cases if c.id == args.plant]
        if not found:
            ids = ", ".join(c.id for r in robots for c in r.cases)
            print(f"verify.py: error: no case {args.plant!r}; the cases are {ids}", file=sys.stderr)
            return 2
        print(planted_text(*found[0]), end="")
        return 0
    problems, count = [], 0
    seen: set[str] = set()
    for robot in robots:
        try:
            verify_equivalent(robot)
        except CorpusError as exc:
            problems.append(str(exc))
        for case in robot.cases:
            count += 1
            if case.id in seen:
                problems.append(f"{case.id}: the id is used twice")
            seen.add(case.id)
            try:
                verify_case(robot, case)
            except CorpusError as exc:
                problems.append(str(exc))
    for line in problems:
        print(line)
    print(f"explain corpus: {len(robots)} robots, {count} cases, {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
