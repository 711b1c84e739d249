"""Power (Section 19.4): P = F . v, P = Gamma omega, and P_av = U12 / (t2 - t1), closed form for any parameters.

A constant force F on the cart (total mass m = m_cart + m_wheel) and a constant couple Gamma on
the flywheel (moment of inertia I about its axle), both from rest at t = 0 (or from v0, omega0):

    v(t) = v0 + F t / m,      omega(t) = omega0 + Gamma t / I
    P(t) = F v(t) + Gamma omega(t)                                       (19.22, 19.23)
    U(t) = integral_0^t P dt = T(t) - T(0)
         = F (v0 t + F t^2 / (2 m)) + Gamma (omega0 t + Gamma t^2 / (2 I))
    P_av = U12 / (t2 - t1)                                           (19.24)

Interface: see ``examples/textbook/rolling_disk/closed_form.py``; ``simulated`` reads the
power as tau . v off the motion (tau is the scene's constant torque) and integrates it with
the trapezoidal rule, which is exact for a power linear in t.
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


def power(tau, rate):
    """P = tau . v [W], summed over the last axis (19.22: a force and a speed; 19.23: a couple and omega)."""
    return np.sum(np.asarray(tau) * np.asarray(rate), axis=-1)


def speeds(t, p):
    """(v(t) [m/s], omega(t) [rad/s])."""
    t = np.asarray(t)
    return p["v0"] + p["F"] * t / p["m"], p["omega0"] + p["Gamma"] * t / p["I"]


def joint_power(t, p):
    """{"rail": F v(t), "flywheel": Gamma omega(t)} [W]."""
    v, omega = speeds(t, p)
    return {"rail": p["F"] * v, "flywheel": p["Gamma"] * omega}


def work(t, p):
    """U(t) = integral_0^t P dt [J] (= T(t) - T(0))."""
    t = np.asarray(t)
    return p["F"] * (p["v0"] * t + p["F"] * t**2 / (2 * p["m"])) + p["Gamma"] * (
        p["omega0"] * t + p["Gamma"] * t**2 / (2 * p["I"])
    )


def average_power(t1, t2, p):
    """P_av = (U(t2) - U(t1)) / (t2 - t1) [W] (Eq. 19.24)."""
    return (work(t2, p) - work(t1, p)) / (t2 - t1)


def urdf_parameters(urdf):
    """m [kg]: everything the rail carries; I [kg m^2]: the flywheel's izz (its axle is z)."""
    root = ET.parse(urdf).getroot()
    links = {link.get("name"): link for link in root.findall("link")}
    joints = {joint.get("name"): joint for joint in root.findall("joint")}
    axis = [float(x) for x in joints["flywheel"].find("axis").get("xyz").split()]
    if axis != [0.0, 0.0, 1.0]:
        raise ValueError(f"{urdf}: the flywheel must turn about 0 0 1, got {axis}")
    cart, wheel = (links[joints[j].find("child").get("link")] for j in ("rail", "flywheel"))
    if wheel.find("inertial/origin").get("xyz").split() != ["0", "0", "0"]:
        raise ValueError(f"{urdf}: the flywheel's centre of mass must be on its axle (inertial origin 0 0 0)")

    def mass(link):
        return float(link.find("inertial/mass").get("value"))

    return {"m": mass(cart) + mass(wheel), "I": float(wheel.find("inertial/inertia").get("izz"))}


def parameters(scene):
    """m, I from the URDF; F, Gamma from the scene's constant torque; v0, omega0 from [initial]."""
    scene = Path(scene)
    data = tomllib.loads(scene.read_text(encoding="utf-8"))
    params = urdf_parameters(scene.parent / data["model"]["urdf"])
    torque = data["control"]["torque"]
    params["F"], params["Gamma"] = float(torque.get("rail", 0.0)), float(torque.get("flywheel", 0.0))
    v = data.get("initial", {}).get("v", {})
    params["v0"], params["omega0"] = float(v.get("rail", 0.0)), float(v.get("flywheel", 0.0))
    return params


def closed_form(t, q: Mapping, v: Mapping, params):
    """P(t) [W] and U(t) [J], with t measured from the start of the motion."""
    t = np.asarray(t) - np.asarray(t)[0]
    return {"power": sum(joint_power(t, params).values()), "work": work(t, params)}


def simulated(t, q: Mapping, v: Mapping, params):
    """P = F v_rail + Gamma omega_flywheel on the simulated motion, and its trapezoidal integral."""
    t = np.asarray(t)
    P = params["F"] * np.asarray(v["rail"]) + params["Gamma"] * np.asarray(v["flywheel"])
    U = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(t))])
    return {"power": P, "work": U}
