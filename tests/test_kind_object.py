"""A kind is one object: a kind registered once reaches every place a kind must reach.

The fixture registers a toy kind (a simple pendulum: URDF, closed form, reader, units) at run time,
in :data:`robodyn.kinds.catalog.KINDS` alone, and the tests find it in the parameter reader, the
units ``robodyn params`` prints, ``robodyn check --formula``, the help strings and the messages
that list the kinds. A place that kept its own list of kinds would miss it and fail here.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import robodyn
from robodyn.cli import get_argument_parser, main
from robodyn.kinds import catalog, params
from robodyn.kinds.bodies import EY, EZ, along, axis_inertia, require_axis, require_gravity, require_joints
from robodyn.kinds.formula import ClosedForm
from robodyn.kinds.kind import Kind

# The bob of the toy URDF: 1 kg at 0.5 m below the axis, 1e-4 kg m^2 about its centre of mass.
BOB = {"m": 1.0, "l": 0.5, "I": 1e-4, "g": 9.81}
READ_RTOL = 1e-12  # the reader takes the URDF's numbers through one rotation: a few roundings

TOY_URDF = """<?xml version="1.0"?>
<!--
  toy_pendulum: a simple pendulum, hanging down (-z) at q = 0.
-->
<robot name="toy_pendulum">
  <link name="base"/>
  <link name="bob">
    <inertial><origin xyz="0 0 -0.5"/><mass value="1.0"/>
      <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="pivot" type="revolute"><parent link="base"/><child link="bob"/><axis xyz="0 1 0"/>
    <limit lower="-1000" upper="1000" effort="10" velocity="100"/></joint>
</robot>
"""


def _read(bodies, gravity_vector):
    require_joints("toy_pendulum", bodies, ("R",))
    (bob,) = bodies
    require_axis("toy_pendulum", bob, EY, "angular")
    length = along("toy_pendulum", "the bob", bob.com - bob.origin, -EZ, EY)
    g = require_gravity("toy_pendulum", gravity_vector)
    return {"m": bob.mass, "l": length, "I": axis_inertia(bob, EY), "g": g}


TOY = Kind(
    "toy_pendulum",
    ClosedForm(
        ("m", "l", "I", "g"),
        1,
        lambda p, q: (p[0] * p[1] * p[1] + p[2] + 0.0 * q,),
        lambda p, q, v: (0.0 * p[0] * v,),
        lambda p, q: (p[0] * p[3] * p[1] * np.sin(q),),
        lambda p, q: p[0] * p[3] * p[1] * (1.0 - np.cos(q)),
    ),
    _read,
    {"m": "kg", "l": "m", "I": "kg m^2", "g": "m/s^2"},
)


@pytest.fixture
def toy(tmp_path, monkeypatch):
    """The toy kind registered for one test; the path of its URDF."""
    monkeypatch.setitem(catalog.KINDS._items, TOY.name, TOY)
    urdf = tmp_path / "toy_pendulum.urdf"
    urdf.write_text(TOY_URDF, encoding="utf-8")
    return urdf


def test_the_parameter_reader_reads_the_toy_kind(toy):
    read = params.extract(robodyn.load(toy), "toy_pendulum").as_dict()
    assert read == pytest.approx(BOB, rel=READ_RTOL)
    assert catalog.get("toy_pendulum") is TOY.formula


def test_robodyn_params_prints_the_toy_kinds_units(toy, capsys):
    assert main(["params", str(toy), "--kind", "toy_pendulum"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["units"] == dict(TOY.units)
    assert printed["params"] == pytest.approx(BOB, rel=READ_RTOL)


def test_robodyn_check_compares_the_toy_kinds_closed_form(toy, capsys):
    assert main(["check", str(toy), "--formula", "toy_pendulum"]) == 0
    out = capsys.readouterr().out
    assert "PASS" in out and "toy_pendulum" in out


def test_every_help_string_that_lists_the_kinds_lists_the_toy_kind(toy):
    assert "toy_pendulum" in catalog.listed()
    parser = get_argument_parser()
    listing = []
    for sub in next(a for a in parser._actions if a.choices and "check" in a.choices).choices.values():
        for action in sub._actions:
            # bench's default workload (default: the three models the benchmark guide measures) is no listing
            if action.help and "pendubot" in action.help and "(default: pendubot" not in action.help:
                listing.append(action.help)
                assert "toy_pendulum" in action.help, action.help
    assert len(listing) >= 5  # check --formula, params --kind, and the model argument of simulate, info, derive


def test_each_built_in_kind_has_its_urdf_and_its_compiled_code():
    from robodyn.engine import closed_form as fast
    from robodyn.model.files import BUILTIN_NAMES

    for kind in catalog.kinds():
        assert kind.name in BUILTIN_NAMES, f"models/{kind.name}.urdf is missing"
        assert kind.code is None or fast.CODES[kind.name] == kind.code, kind.name
    assert {k.name: k.code for k in catalog.kinds() if k.code is not None} == fast.CODES
