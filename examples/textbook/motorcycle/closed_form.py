"""Example 19.2: the motorcycle driven by a couple on its rear wheel, the book's closed form for any parameters.

The couple Gamma acts between the body and the rear wheel. The road's forces do no work (the
contact points are at rest) and neither do the weights (the road is level), so the work of
the couple, Gamma times the rear wheel's angle b / R, equals the kinetic energy (19.21):

    Gamma b / R = 1/2 m_c v^2 + 2 (1/2 m_w v^2 + 1/2 I omega^2),   omega = v / R
    b(v)    = (1/2 m_c + m_w + I / R^2) R v^2 / Gamma              (the book: 128.68 m for 25 m/s)

In general, with the scene's couplings wheel = ratio * drive (ratio = 1/R [rad/m]), any
masses and inertias, and an initial speed v0:

    Gamma ratio_rear b = 1/2 m_eff (v^2 - v0^2),   m_eff = m_body + m_rear + m_front
                                                       + I_rear ratio_rear^2 + I_front ratio_front^2.

The motion has constant acceleration a = Gamma ratio_rear / m_eff. Interface: see
``examples/textbook/rolling_disk/closed_form.py`` (parameters, closed_form, simulated).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path

import numpy as np

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

GRAVITY = 9.81  # Pinocchio's default |g| [m/s^2]; it does no work on a level road


def effective_mass(params):
    """m_eff [kg]: the kinetic energy is 1/2 m_eff v^2."""
    p = params
    return (
        p["m_body"]
        + p["m_rear"]
        + p["m_front"]
        + p["I_rear"] * p["ratio_rear"] ** 2
        + p["I_front"] * p["ratio_front"] ** 2
    )


def distance_to_reach(speed, params):
    """b [m] travelled from speed ``params["v0"]`` to ``speed`` [m/s]: Gamma ratio_rear b = 1/2 m_eff (v^2 - v0^2)."""
    p = params
    return 0.5 * effective_mass(p) * (np.asarray(speed) ** 2 - p["v0"] ** 2) / (p["Gamma"] * p["ratio_rear"])


def book_distance(speed, m_c, m_w, I, R, Gamma):
    """The book's b = (m_c / 2 + m_w + I / R^2) R v^2 / Gamma, from rest, two equal wheels [m]."""
    return (0.5 * m_c + m_w + I / R**2) * R * np.asarray(speed) ** 2 / Gamma


def speed_after(b, params):
    """Speed [m/s] after a distance ``b`` [m]."""
    p = params
    return np.sqrt(p["v0"] ** 2 + 2.0 * p["Gamma"] * p["ratio_rear"] * np.asarray(b) / effective_mass(p))


def acceleration(params):
    """The constant acceleration [m/s^2]: Gamma ratio_rear / m_eff."""
    return params["Gamma"] * params["ratio_rear"] / effective_mass(params)


def engine_power(speed, params):
    """P = Gamma omega_rear = Gamma ratio_rear v [W] (Eq. 19.23)."""
    return params["Gamma"] * params["ratio_rear"] * np.asarray(speed)


def _mass(link):
    return float(link.find("inertial/mass").get("value"))


def urdf_parameters(urdf):
    """Masses [kg], the wheels' inertias about their axles [kg m^2] and radii [m] from ``motorcycle.urdf``."""
    root = ET.parse(urdf).getroot()
    links = {link.get("name"): link for link in root.findall("link")}
    joints = {joint.get("name"): joint for joint in root.findall("joint")}
    out = {"m_body": _mass(links[joints["drive"].find("child").get("link")])}
    for wheel in ("rear", "front"):
        joint = joints[f"{wheel}_wheel"]
        axis = [float(x) for x in joint.find("axis").get("xyz").split()]
        if axis != [0.0, 1.0, 0.0]:
            raise ValueError(f"{urdf}: {wheel}_wheel must turn about 0 1 0 (the axle), got {axis}")
        link = links[joint.find("child").get("link")]
        out[f"m_{wheel}"] = _mass(link)
        out[f"I_{wheel}"] = float(link.find("inertial/inertia").get("iyy"))
        out[f"R_{wheel}"] = float(link.find("visual/geometry/cylinder").get("radius"))
    return out


def parameters(scene):
    """Everything the closed form needs, from the scene file and its URDF.

    ``Gamma`` is the scene's constant torque on ``rear_wheel`` [N m]; ``ratio_rear`` and
    ``ratio_front`` the couplings wheel = ratio * drive [rad/m]; ``v0`` the initial speed.
    """
    scene = Path(scene)
    data = tomllib.loads(scene.read_text(encoding="utf-8"))
    params = urdf_parameters(scene.parent / data["model"]["urdf"])
    ratios = {c["joint"]: float(c["ratio"]) for c in data["constraints"]["couplings"] if c["leader"] == "drive"}
    params["ratio_rear"], params["ratio_front"] = ratios["rear_wheel"], ratios["front_wheel"]
    params["Gamma"] = float(data["control"]["torque"]["rear_wheel"])
    params["v0"] = float(data.get("initial", {}).get("v", {}).get("drive", 0.0))
    params["g"] = GRAVITY
    return params


def closed_form(t, q: Mapping, v: Mapping, params):
    """The book's speed after the distance travelled so far [m/s]."""
    b = np.asarray(q["drive"]) - np.asarray(q["drive"])[0]
    return {"speed": speed_after(b, params)}


def simulated(t, q: Mapping, v: Mapping, params):
    """The simulated speed [m/s]."""
    return {"speed": np.asarray(v["drive"])}
