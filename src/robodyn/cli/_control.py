"""``--controller NAME_OR_FILE.py [--gains JSON_OR_FILE]``: a controller of :mod:`robodyn.control` on the CLI.

The gains are a JSON object of keyword arguments to :func:`robodyn.control.make` (e.g.
``'{"Q": [10, 10, 1, 1], "R": 0.1}'``), given inline or as the path of a file holding one.
Every problem is one line naming the flag: an unknown controller (with close matches), a gain
of the wrong shape (the shape expected), a controller file that raises (its file and line), an
equilibrium that is not one (its residual).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from robodyn.cli._common import print_json, shown
from robodyn.errors import InputError, UnknownNameError

# A gains file is a few lines of JSON; a larger one is not read (and /dev/zero never ends).
MAX_GAINS_BYTES = 2**20


def parse_gains(text: str | None) -> dict[str, Any]:
    """The ``--gains`` object: inline JSON (starting with ``{``) or the path of a JSON file; {} when not given.

    Raises:
        InputError: not a JSON object, or a file that cannot be read; one line naming --gains.
    """
    if text is None:
        return {}
    where = "--gains"
    if not text.lstrip().startswith(("{", "[", '"')) and Path(text).is_file():
        where = f"--gains {text}"
        text = _read_gains_file(Path(text), where)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        if where == "--gains" and not text.lstrip().startswith(("{", "[", '"')):
            raise InputError(
                f"--gains {shown(text)}: neither a JSON object like '{{\"R\": 0.1}}' nor a file holding one"
            ) from None
        raise InputError(f"{where}: not valid JSON ({exc.msg} at line {exc.lineno} column {exc.colno})") from None
    except (RecursionError, ValueError) as exc:
        raise InputError(f"{where}: cannot be read ({type(exc).__name__}); expected a flat JSON object") from None
    if not isinstance(data, dict):
        raise InputError(f'{where}: expected a JSON object of gains like {{"R": 0.1}}, got {type(data).__name__}')
    return data


def _read_gains_file(path: Path, where: str) -> str:
    """The text of a gains file: UTF-8, at most :data:`MAX_GAINS_BYTES`."""
    try:
        with path.open("rb") as stream:
            raw = stream.read(MAX_GAINS_BYTES + 1)
    except OSError as exc:
        raise InputError(f"{where}: cannot read it: {exc.strerror or exc}") from None
    if len(raw) > MAX_GAINS_BYTES:
        raise InputError(f"{where}: larger than 1 MiB (expected a short JSON object)")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{where}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start})") from None


def build(robot: Any, name: str, gains: dict[str, Any]) -> Any:
    """The torque callable tau(t, q, v) of controller ``name`` for ``robot``, its errors naming --controller."""
    from robodyn import control

    try:
        return control.make(name, robot, **gains)
    except UnknownNameError as exc:
        flag = "--controller" if exc.what == "controller" else "--gains"
        raise InputError(f"{flag}: {exc}") from None
    except InputError as exc:
        raise InputError(f"--controller {name}: {exc}") from None


def describe(name: str, gains: dict[str, Any]) -> str:
    """``swing_up (gains: R=0.1)``, or ``swing_up (default gains)``: the controller, for the summary."""
    if not gains:
        return f"{name} (default gains)"
    return f"{name} (gains: " + ", ".join(f"{k}={json.dumps(v)}" for k, v in gains.items()) + ")"


def print_controllers(*, as_json: bool) -> None:
    """The built-in controllers, one per line (or as JSON)."""
    from robodyn import control

    rows = [{"name": n, "description": control.CONTROLLERS.get(n).summary} for n in control.names()]
    if as_json:
        print_json(rows)
        return
    for row in rows:
        print(f"{row['name']:<10} {row['description']}")
    print("or a file NAME.py defining make(robot, **gains) that returns tau(t, q, v)")


def outcome(controller: Any, trajectory: Any) -> Any:
    """The :class:`robodyn.control.outcome.Outcome` of a swing-up run (balanced or not, and why), or None.

    Only a built-in ``swing_up`` has a goal to judge: other controllers return None.
    """
    from robodyn.control import Switched
    from robodyn.control.outcome import judge

    if not isinstance(controller, Switched) or len(trajectory.t) < 2:
        return None
    return judge(controller, trajectory.t, trajectory.q, trajectory.v, trajectory.tau)
