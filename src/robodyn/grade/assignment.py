"""The assignment file (TOML): the model, what is asked and for how many points, the limits, the feedback.

An example (``examples/grading/pendubot.toml``; the guide is ``docs/guides/grading.md``)::

    model = "pendubot"               # a built-in name, or a URDF path relative to this file
    tolerance = 1e-9                 # relative, as robodyn check --rtol
    samples = 20                     # seeded random states per submission
    seed = 0
    christoffel = true               # C must be the Christoffel matrix (false: C v is graded)
    feedback = "terms"               # "terms" | "entries" | "verdict"
    time_limit = 20                  # [s] a submission's code may run (import, then its evaluations)
    memory_mb = 2048                 # [MiB] address space of the process that runs a submission
    file = "dynamics.py"             # optional: the file to grade inside a student's folder

    [points]                         # what is asked: any of M, C, G, V
    M = 4
    C = 3
    G = 2

    [coordinates]                    # optional: coordinates fixed by the teacher (the student's are ignored)
    joints = ["shoulder", "elbow"]
    map = [[1, 0], [1, 1]]           # or {joint = [sign, offset]}; offsets = [...] with a matrix
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robodyn.errors import InputError
from robodyn.fileio import toml_module

QUANTITIES = ("M", "C", "G", "V")
FEEDBACK = ("terms", "entries", "verdict")
KEYS = (
    "model", "tolerance", "samples", "seed", "christoffel", "feedback", "time_limit", "memory_mb", "file",
    "points", "coordinates", "title",
)  # fmt: skip
MAX_SAMPLES = 10_000
MAX_TIME_LIMIT = 3600.0
MIN_MEMORY_MB = 256  # a Python with NumPy needs ~100 MiB of address space before any user code runs


@dataclass(frozen=True)
class Assignment:
    """A parsed assignment: every value checked, the model's path resolved beside the file."""

    path: Path
    model: str  # a built-in name, or an absolute URDF path
    points: dict[str, float]  # quantity ("M", "C", "G", "V") -> points
    tolerance: float = 1e-9
    samples: int = 20
    seed: int = 0
    christoffel: bool = True
    feedback: str = "terms"
    time_limit: float = 20.0  # [s]
    memory_mb: int = 2048  # [MiB]
    file: str | None = None
    title: str = ""
    coordinates: dict[str, Any] = field(default_factory=dict)  # joints, map, offsets (teacher-fixed)

    @property
    def max_score(self) -> float:
        """The points of everything asked."""
        return float(sum(self.points.values()))

    def coordinate_lines(self) -> str:
        """Python lines that fix the teacher's coordinates, appended to a submission ('' when the student's own)."""
        if not self.coordinates:
            return ""
        c = self.coordinates
        lines = ["", "# coordinates fixed by the assignment (robodyn grade)", f"JOINTS = {list(c['joints'])!r}"]
        lines.append(f"COORDINATES = {c['map']!r}")
        if "offsets" in c:
            lines.append(f"OFFSETS = {list(c['offsets'])!r}")
        return "\n".join(lines) + "\n"


def _number(raw: Mapping[str, Any], key: str, default: float, where: str, *, low: float, high: float) -> float:
    value = raw.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"{where}: {key} must be a number, got {value!r}")
    if not low < value <= high:
        raise InputError(f"{where}: {key} must be > {low:g} and <= {high:g}, got {value!r}")
    return float(value)


def _points(raw: Any, where: str) -> dict[str, float]:
    if not isinstance(raw, dict) or not raw:
        raise InputError(f"{where}: [points] must give the points of at least one of {', '.join(QUANTITIES)}")
    out = {}
    for name in raw:
        if name not in QUANTITIES:
            raise InputError(f"{where}: [points] names {name!r}; expected any of {', '.join(QUANTITIES)}")
        out[name] = _number(raw, name, 0.0, f"{where} [points]", low=0.0, high=1e6)
    return {q: out[q] for q in QUANTITIES if q in out}


def _coordinates(raw: Any, where: str) -> dict[str, Any]:
    if raw is None:
        return {}
    joints = raw.get("joints") if isinstance(raw, dict) else None
    if not isinstance(joints, list) or not joints or not all(isinstance(j, str) for j in joints) or "map" not in raw:
        raise InputError(f"{where}: [coordinates] needs joints (a list of joint names) and map (a matrix or a table)")
    unknown = set(raw) - {"joints", "map", "offsets"}
    if unknown:
        raise InputError(f"{where}: [coordinates] has {', '.join(sorted(unknown))}; expected joints, map, offsets")
    mapping = raw["map"]
    if isinstance(mapping, dict):
        mapping = {j: tuple(float(x) for x in pair) for j, pair in mapping.items()}
    return {**raw, "map": mapping}


def load_assignment(path: str | Path) -> Assignment:
    """Read and check an assignment file; one-line :class:`InputError` naming the key on anything wrong."""
    path = Path(path)
    where = str(path)
    toml = toml_module("assignment files")
    try:
        raw = toml.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"{where}: cannot read the assignment: {exc.strerror}") from None
    except toml.TOMLDecodeError as exc:
        raise InputError(f"{where}: not valid TOML: {exc}") from None
    unknown = sorted(set(raw) - set(KEYS))
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(unknown)}; expected {', '.join(KEYS)}")
    model = raw.get("model")
    if not isinstance(model, str) or not model:
        raise InputError(f"{where}: model must be a built-in name or a URDF path beside the assignment")
    if model.endswith(".urdf"):
        model = str((path.parent / model).resolve())
    feedback = raw.get("feedback", "terms")
    if feedback not in FEEDBACK:
        raise InputError(f"{where}: feedback must be one of {', '.join(FEEDBACK)}, got {feedback!r}")
    christoffel = raw.get("christoffel", True)
    if not isinstance(christoffel, bool):
        raise InputError(f"{where}: christoffel must be true or false, got {christoffel!r}")
    samples = _number(raw, "samples", 20, where, low=0, high=MAX_SAMPLES)
    seed = raw.get("seed", 0)
    if samples != int(samples) or not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise InputError(f"{where}: samples and seed must be whole numbers (samples >= 1, seed >= 0)")
    return Assignment(
        path=path.resolve(),
        model=model,
        points=_points(raw.get("points"), where),
        tolerance=_number(raw, "tolerance", 1e-9, where, low=0.0, high=1.0),
        samples=int(samples),
        seed=seed,
        christoffel=christoffel,
        feedback=feedback,
        time_limit=_number(raw, "time_limit", 20.0, where, low=0.0, high=MAX_TIME_LIMIT),
        memory_mb=int(_number(raw, "memory_mb", 2048, where, low=MIN_MEMORY_MB - 1, high=1 << 20)),
        file=raw.get("file"),
        title=str(raw.get("title", path.stem)),
        coordinates=_coordinates(raw.get("coordinates"), where),
    )
