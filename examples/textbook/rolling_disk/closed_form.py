"""Example 19.1: a disk rolling (or sliding) down an incline, the book's closed form for any parameters.

Work and energy (19.20) with the rolling kinematics omega = v / R give

    v(b) = sqrt(2 g b sin(beta) / (1 + I / (m R^2)))          (rolling)
    v(b) = sqrt(2 g b sin(beta))                              (sliding: no coupling)

where b is the distance travelled along the slope [m]. Here the rolling kinematics is the
scene's coupling spin = ratio * slide (ratio = 1/R [rad/m]), so in general

    v(b)^2 = v0^2 + 2 g b sin(beta) / (1 + I ratio^2 / m),

with m everything the slide carries [kg] and I the spinning disk's moment of inertia about
its axis [kg m^2]. Without the coupling ratio = 0. The interface shared by every
``examples/textbook/*/closed_form.py``:

* ``parameters(scene) -> dict``: every parameter, read from the scene file and its URDF;
* ``closed_form(t, q, v, params) -> dict``: the book's prediction of named quantities along
  a motion (t (n,) [s]; q, v: joint name -> (n,) arrays);
* ``simulated(t, q, v, params) -> dict``: the same quantities read off the motion.

``robodyn run`` compares the two (max |closed form - simulated| over the motion, divided by
the largest |closed form|: ``robodyn.kinds.deviation.worst_deviation``).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path

import numpy as np

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

GRAVITY = 9.81  # Pinocchio's default |g| [m/s^2]


def speed_after(b, params):
    """Speed of the centre [m/s] after a distance ``b`` [m] down the slope, from speed ``params["v0"]``."""
    p = params
    effective = 1.0 + p["I"] * p["ratio"] ** 2 / p["m"]
    return np.sqrt(p["v0"] ** 2 + 2.0 * p["g"] * np.asarray(b) * math.sin(p["beta"]) / effective)


def acceleration(params):
    """The centre's constant acceleration along the slope [m/s^2]: g sin(beta) / (1 + I ratio^2 / m)."""
    p = params
    return p["g"] * math.sin(p["beta"]) / (1.0 + p["I"] * p["ratio"] ** 2 / p["m"])


def _rpy(element):
    origin = element.find("origin")
    return [float(x) for x in origin.get("rpy", "0 0 0").split()] if origin is not None else [0.0, 0.0, 0.0]


def _mass(link):
    mass = link.find("inertial/mass")
    return float(mass.get("value")) if mass is not None else 0.0


def urdf_parameters(urdf):
    """beta [rad], m [kg], I [kg m^2], R [m] from ``disk.urdf`` (or any URDF of the same tree)."""
    root = ET.parse(urdf).getroot()
    links = {link.get("name"): link for link in root.findall("link")}
    joints = {joint.get("name"): joint for joint in root.findall("joint")}
    roll, pitch, yaw = _rpy(joints["incline"])
    if roll != 0.0 or yaw != 0.0:
        raise ValueError(f"{urdf}: the incline must only pitch about y (rpy = 0 beta 0), got {roll, pitch, yaw}")
    spin_axis = [float(x) for x in joints["spin"].find("axis").get("xyz").split()]
    if spin_axis != [0.0, 1.0, 0.0]:
        raise ValueError(f"{urdf}: the spin axis must be 0 1 0 (across the slope), got {spin_axis}")
    disk = links[joints["spin"].find("child").get("link")]
    hub = links[joints["slide"].find("child").get("link")]
    inertia = disk.find("inertial/inertia")
    return {
        "beta": pitch,
        "m": _mass(hub) + _mass(disk),
        "I": float(inertia.get("iyy")),
        "R": float(disk.find("visual/geometry/cylinder").get("radius")),
    }


def parameters(scene):
    """Everything the closed form needs, from the scene file and the URDF it names.

    ``ratio`` is the scene's coupling spin = ratio * slide (0 without one: sliding), ``v0``
    the initial speed of the slide [m/s], ``g`` Pinocchio's gravity.
    """
    scene = Path(scene)
    data = tomllib.loads(scene.read_text(encoding="utf-8"))
    params = urdf_parameters(scene.parent / data["model"]["urdf"])
    couplings = data.get("constraints", {}).get("couplings", [])
    rolling = [c for c in couplings if c["joint"] == "spin" and c["leader"] == "slide"]
    params["ratio"] = float(rolling[0]["ratio"]) if rolling else 0.0
    params["v0"] = float(data.get("initial", {}).get("v", {}).get("slide", 0.0))
    params["g"] = GRAVITY
    return params


def closed_form(t, q: Mapping, v: Mapping, params):
    """The book's speed v(b) at each sample, b = slide - slide(0) [m/s]."""
    b = np.asarray(q["slide"]) - np.asarray(q["slide"])[0]
    return {"speed": speed_after(b, params)}


def simulated(t, q: Mapping, v: Mapping, params):
    """The simulated speed of the slide [m/s]."""
    return {"speed": np.asarray(v["slide"])}
