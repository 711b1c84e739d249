"""What a trajectory ``.npz`` must hold before robodyn reads or plays it: shapes, types, times, finite numbers.

A trajectory file may come from anywhere (an old run, another tool, a hand edit), and the
viewer draws whatever it is given: a NaN becomes a blank chart, a 3-D energy array a chart of
nothing. So every file is checked, one line naming the array and what was expected:

* :func:`array_headers` reads each array's declared dtype and shape from the archive before
  anything is allocated: a shape that its stored bytes do not hold, an object (pickled) array
  or more than :data:`MAX_TRAJECTORY_BYTES` in all is refused unread;
* :func:`check_arrays` checks the loaded arrays: ranks, one row per sample of ``t``, ``t``
  finite and strictly increasing, every value finite (the first non-finite sample named), the
  energy T + V, the power tau * v and the ledger E - E(0) - W finite (1e308 torques overflow them);
* :func:`check_metadata` checks the JSON metadata's types;
* :func:`check_fits` checks a trajectory against the model it is played on: the columns of
  q and v, and the joint names the file records.
"""

from __future__ import annotations

import math
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import InputError

if TYPE_CHECKING:
    from robodyn.robot import Robot

STATUSES = ("ok", "diverged", "interrupted")
"""How a run ended: every step taken, stopped as diverged, or interrupted (Ctrl-C)."""

MAX_TRAJECTORY_BYTES = 2**31
"""Bytes of array data one trajectory file may hold, 2 GiB: a 7-joint run of 5 million samples (83 minutes at
dt = 1 ms) needs 1.4 GiB; a file that declares more is refused before anything is allocated."""

ROWS = ("kinetic", "potential", "work_input", "work_damping", "work_limits", "constraint_drift")
"""Arrays of one number per sample, shape (n,)."""
MATRICES = ("q", "v", "a", "tau")
"""Arrays of one row per sample, shape (n, nq) for q, (n, nv) for the others."""
_NUMERIC_KINDS = "fiu"  # float, signed and unsigned integers: converted to float64 exactly (or to the nearest)


def array_headers(path: Path, names: tuple[str, ...]) -> dict[str, tuple[tuple[int, ...], np.dtype[Any]]]:
    """Each of ``names`` present in the archive: its declared (shape, dtype), read without loading it.

    Raises:
        InputError: a member that is not a NumPy array, an object or non-numeric array, a shape
            that its stored bytes do not hold, or more than :data:`MAX_TRAJECTORY_BYTES` in all.
    """
    out: dict[str, tuple[tuple[int, ...], np.dtype[Any]]] = {}
    total = 0
    with zipfile.ZipFile(path) as archive:
        members = {info.filename: info for info in archive.infolist()}
        for name in names:
            info = members.get(f"{name}.npy")
            if info is None:
                continue
            with archive.open(info) as member:
                try:
                    version = np.lib.format.read_magic(member)
                    reader = (
                        np.lib.format.read_array_header_1_0
                        if version == (1, 0)
                        else np.lib.format.read_array_header_2_0
                    )
                    shape, _, dtype = reader(member)
                except ValueError as exc:
                    reason = str(exc).splitlines()[0] if str(exc) else "unreadable header"
                    raise InputError(f"{path}: array {name!r} is not a NumPy array ({reason[:120]})") from None
                offset = member.tell()
            if dtype.hasobject:
                raise InputError(f"{path}: array {name!r} holds Python objects; expected numbers (float64)")
            declared = math.prod(shape) * dtype.itemsize  # Python integers: no overflow
            if declared != info.file_size - offset:
                raise InputError(
                    f"{path}: array {name!r} declares shape {tuple(shape)} of {dtype} ({declared:,} bytes) "
                    f"but stores {max(info.file_size - offset, 0):,} bytes; the file is damaged or forged"
                )
            total += declared
            if total > MAX_TRAJECTORY_BYTES:
                raise InputError(
                    f"{path}: its arrays hold more than {MAX_TRAJECTORY_BYTES / 2**30:g} GiB "
                    f"(array {name!r} declares shape {tuple(shape)}); refused before reading"
                )
            out[name] = (tuple(shape), dtype)
    return out


def check_dtypes(path: Path, headers: Mapping[str, tuple[tuple[int, ...], np.dtype[Any]]]) -> None:
    """Raise :class:`InputError` unless every array holds real numbers and the metadata is one string."""
    for name, (shape, dtype) in headers.items():
        if name == "metadata":
            if dtype.kind not in "US" or shape != ():
                raise InputError(
                    f"{path}: 'metadata' is an array of {dtype} with shape {shape}; expected one JSON string"
                )
        elif dtype.kind not in _NUMERIC_KINDS or dtype.names is not None:
            what = "complex numbers" if dtype.kind == "c" else f"{dtype}"
            raise InputError(f"{path}: array {name!r} holds {what}; expected real numbers (float64)")


def check_arrays(path: Path, arrays: Mapping[str, NDArray[np.float64]], *, finite: bool = True) -> None:
    """Raise :class:`InputError` unless ``arrays`` form one trajectory: shapes, times, finite values.

    ``t`` (n,) finite and strictly increasing with n >= 1; each of :data:`ROWS` present (n,);
    each of :data:`MATRICES` (n, k), v, a and tau with one column count; with ``finite`` (a run
    that ended ``ok``), every value finite and T + V and tau * v finite too. A diverged or
    interrupted run's partial file may end on non-finite samples: it stays readable (what it
    computed is kept), and the viewer refuses to draw what is not finite.
    """
    t = arrays["t"]
    if t.ndim != 1 or t.shape[0] == 0:
        raise InputError(f"{path}: array 't' has shape {t.shape}; expected (n,) with n >= 1 sample times [s]")
    n = t.shape[0]
    for name in ROWS:
        if name in arrays and arrays[name].shape != (n,):
            raise InputError(f"{path}: array {name!r} has shape {arrays[name].shape}; expected ({n},), one per t")
    for name in MATRICES:
        shape = arrays[name].shape
        if len(shape) != 2 or shape[0] != n:
            raise InputError(
                f"{path}: array {name!r} has shape {shape}; expected ({n}, columns), one row per t "
                "(samples x coordinates)"
            )
    nv = arrays["v"].shape[1]
    for name in ("a", "tau"):
        if arrays[name].shape[1] != nv:
            raise InputError(f"{path}: array {name!r} has {arrays[name].shape[1]} columns but 'v' has {nv}")
    for name, values in arrays.items():
        if finite or name == "t":
            _check_finite(path, name, values, t)
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0))
        how = "repeats" if steps[k] == 0 else "goes back"
        raise InputError(
            f"{path}: 't' {how} at sample {k + 1} (t = {t[k]:.9g} s, then {t[k + 1]:.9g} s); "
            "expected strictly increasing times"
        )
    if not finite:
        return
    with np.errstate(over="ignore", invalid="ignore"):
        derived = {
            "the energy T + V": arrays["kinetic"] + arrays["potential"],
            "the power tau * v": np.sum(arrays["tau"] * arrays["v"], axis=1) if nv else np.zeros(n),
        }
        energy = derived["the energy T + V"]
        works = arrays["work_input"] + arrays["work_damping"] + arrays.get("work_limits", np.zeros(n))
        derived["the ledger E - E(0) - W"] = energy - energy[0] - works
    for what, values in derived.items():
        _check_finite(path, what, values, t, derived=True)


def _check_finite(
    path: Path, name: str, values: NDArray[np.float64], t: NDArray[np.float64], *, derived: bool = False
) -> None:
    bad = ~np.isfinite(values)
    if not np.any(bad):
        return
    rows = np.asarray(bad.reshape(bad.shape[0], -1).any(axis=1) if bad.ndim else bad.reshape(1))
    count, first = int(rows.sum()), int(np.argmax(rows))
    what = f"{name} overflows float64" if derived else f"array {name!r} is not finite (NaN or infinite)"
    at = f", t = {t[first]:.9g} s" if name != "t" and np.isfinite(t[first]) else ""
    raise InputError(f"{path}: {what} at {count} of {len(rows)} samples (the first: sample {first}{at})")


def check_metadata(path: Path, info: Any) -> None:
    """Raise :class:`InputError` unless the metadata is a JSON object whose known keys have their types."""
    if not isinstance(info, dict):
        raise InputError(f"{path}: not a robodyn trajectory: its metadata is not a JSON object")
    expected: dict[str, tuple[tuple[type, ...], str]] = {
        "meta": ((dict,), "a JSON object"),
        "message": ((str,), "a string"),
        "status": ((str,), f"one of {', '.join(STATUSES)}"),
        "wall_time_s": ((int, float), "a number of seconds >= 0"),
        "evaluations": ((int,), "a whole number >= 0"),
    }
    for key, (types, words) in expected.items():
        if key not in info:
            continue
        value = info[key]
        ok = isinstance(value, types) and not isinstance(value, bool)
        if ok and key == "status":
            ok = value in STATUSES
        if ok and key in ("wall_time_s", "evaluations"):
            ok = math.isfinite(value) and value >= 0
        if not ok:
            raise InputError(f"{path}: metadata {key!r} is {_shown(value)}; expected {words}")
    names = info.get("meta", {}).get("joint_names")
    if names is not None and not (isinstance(names, list) and all(isinstance(n, str) for n in names)):
        raise InputError(f"{path}: metadata meta.joint_names is {_shown(names)}; expected a list of joint names")


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def check_fits(trajectory: Any, robot: Robot, source: Path | str) -> None:
    """Raise :class:`InputError` unless ``trajectory`` (read from ``source``) can be played on ``robot``.

    q must have nq columns, v, a and tau nv; the joint names the file records, when it records
    them, must be the model's.
    """
    nq, nv = trajectory.q.shape[1], trajectory.v.shape[1]
    if (nq, nv) != (robot.nq, robot.nv):
        raise InputError(
            f"{source}: q has {nq} and v {nv} columns but model {robot.name!r} has nq = {robot.nq}, nv = {robot.nv} "
            f"(joints: {', '.join(robot.joint_names)}); was it simulated with another model?"
        )
    names = trajectory.meta.get("joint_names")
    if isinstance(names, list) and tuple(names) != tuple(robot.joint_names):
        recorded = trajectory.meta.get("model")
        model = f" (it was simulated with model {recorded!r})" if isinstance(recorded, str) else ""
        raise InputError(
            f"{source}: names joints {', '.join(names) or '(none)'} but model {robot.name!r} has "
            f"{', '.join(robot.joint_names)}{model}; play it on the model it was simulated with"
        )
