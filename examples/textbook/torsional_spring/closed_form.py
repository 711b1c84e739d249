"""Fig. 19.9: a bar on a torsional spring, the book's potential energy V = k theta^2 / 2 for any parameters.

The spring's couple is M = -k (theta - rest) (opposite to the bar's rotation away from rest).
From M d theta = -dV (19.17), dV/d theta = k (theta - rest), so

    V(theta) = k (theta - rest)^2 / 2                                   (19.18, rest = 0)

The bar turns about a vertical axis (its weight does no work), so T + V is constant (19.19):
a harmonic oscillator with W = sqrt(k / I_A),

    theta(t) = rest + (theta0 - rest) cos(W t) + (omega0 / W) sin(W t).

Interface: see ``examples/textbook/rolling_disk/closed_form.py``.
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


def spring_couple(theta, p):
    """M = -k (theta - rest) [N m]."""
    return -p["k"] * (np.asarray(theta) - p["rest"])


def spring_energy(theta, p):
    """V = k (theta - rest)^2 / 2 [J] (Eq. 19.18)."""
    return 0.5 * p["k"] * (np.asarray(theta) - p["rest"]) ** 2


def angle(t, p):
    """theta(t) [rad] from (theta0, omega0) at t = 0."""
    w = np.sqrt(p["k"] / p["I_A"])
    t = np.asarray(t)
    return p["rest"] + (p["theta0"] - p["rest"]) * np.cos(w * t) + p["omega0"] / w * np.sin(w * t)


def rate(t, p):
    """omega(t) = d theta / dt [rad/s]."""
    w = np.sqrt(p["k"] / p["I_A"])
    t = np.asarray(t)
    return -(p["theta0"] - p["rest"]) * w * np.sin(w * t) + p["omega0"] * np.cos(w * t)


def urdf_parameters(urdf):
    """I_A [kg m^2]: the bar's moment of inertia about the pivot axis (z), izz + m (x_c^2 + y_c^2)."""
    root = ET.parse(urdf).getroot()
    joint = root.find("joint[@name='pivot']")
    axis = [float(x) for x in joint.find("axis").get("xyz").split()]
    if axis != [0.0, 0.0, 1.0]:
        raise ValueError(f"{urdf}: the pivot must turn about 0 0 1 (vertical, so gravity does no work), got {axis}")
    link = root.find(f"link[@name='{joint.find('child').get('link')}']")
    inertial = link.find("inertial")
    if inertial.find("origin").get("rpy", "0 0 0").split() != ["0", "0", "0"]:
        raise ValueError(f"{urdf}: the bar's inertial frame must not be rotated (rpy 0 0 0)")
    m = float(inertial.find("mass").get("value"))
    x, y, _ = (float(c) for c in inertial.find("origin").get("xyz").split())
    return {"I_A": float(inertial.find("inertia").get("izz")) + m * (x**2 + y**2)}


def parameters(scene):
    """I_A from the URDF, k and rest from the scene's [springs] pivot, theta0 and omega0 from [initial]."""
    scene = Path(scene)
    data = tomllib.loads(scene.read_text(encoding="utf-8"))
    params = urdf_parameters(scene.parent / data["model"]["urdf"])
    spring = data["springs"]["pivot"]
    params["k"], params["rest"] = float(spring["stiffness"]), float(spring.get("rest", 0.0))
    initial = data.get("initial", {})
    params["theta0"] = float(initial.get("q", {}).get("pivot", 0.0))
    params["omega0"] = float(initial.get("v", {}).get("pivot", 0.0))
    return params


def closed_form(t, q: Mapping, v: Mapping, params):
    """theta(t) [rad], and the spring's V = k (theta - rest)^2 / 2 [J] at the simulated angle."""
    return {"theta": angle(t, params), "spring_energy": spring_energy(q["pivot"], params)}


def simulated(t, q: Mapping, v: Mapping, params):
    """The simulated angle, and the energy the bar has lost: E0 - I_A omega^2 / 2 [J]."""
    p = params
    energy = 0.5 * p["I_A"] * p["omega0"] ** 2 + spring_energy(p["theta0"], p)
    return {"theta": np.asarray(q["pivot"]), "spring_energy": energy - 0.5 * p["I_A"] * np.asarray(v["pivot"]) ** 2}
