"""Example 19.3: the linkage with a collar on a guide and a torsional spring, closed form for any parameters.

One coordinate is left once the loop is closed: theta, bar AB's angle from the upward
vertical (joint_a). On the loop, bar BC turns at -omega (joint_b = -2 theta relative to AB)
and the collar sits at height 2 l cos(theta). The kinetic and potential energies are

    T = 1/2 M(theta) omega^2,
    M(theta) = I_ab + I_bc + (m_ab + m_bc) l^2 / 4 + 2 (m_bc + 2 m_c) l^2 sin^2(theta)   [kg m^2]
    V(theta) = g l cos(theta) (m_ab / 2 + 3 m_bc / 2 + 2 m_c) + k (theta - rest)^2 / 2       [J]

(I_ab, I_bc about the bars' centres). With the book's bars (m_ab = m_bc = m, I = m l^2 / 12)
M(theta) = 2/3 m l^2 + 2 (m + 2 m_C) l^2 sin^2(theta): twice the book's denominator, since the
book equates T = omega^2 [m l^2 / 3 + (m + 2 m_C) l^2 sin^2(theta)] itself. Energy
conservation from (theta0, omega0) gives

    omega^2(theta) = [M(theta0) omega0^2 + 2 (V(theta0) - V(theta))] / M(theta),

the book's formula when theta0 = omega0 = rest = 0. Interface: see
``examples/textbook/rolling_disk/closed_form.py``.
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

GRAVITY = 9.81  # Pinocchio's default |g| [m/s^2]


def reduced_mass(theta, p):
    """M(theta) [kg m^2]: T = M(theta) omega^2 / 2."""
    s = np.sin(theta)
    return (
        p["I_ab"]
        + p["I_bc"]
        + (p["m_ab"] + p["m_bc"]) * p["l"] ** 2 / 4
        + 2 * (p["m_bc"] + 2 * p["m_c"]) * (p["l"] * s) ** 2
    )


def reduced_mass_slope(theta, p):
    """dM/dtheta [kg m^2/rad] = 4 (m_bc + 2 m_c) l^2 sin(theta) cos(theta)."""
    return 4 * (p["m_bc"] + 2 * p["m_c"]) * p["l"] ** 2 * np.sin(theta) * np.cos(theta)


def weight_moment(p):
    """g l (m_ab / 2 + 3 m_bc / 2 + 2 m_c) [N m]: V_weights = weight_moment cos(theta)."""
    return p["g"] * p["l"] * (p["m_ab"] / 2 + 1.5 * p["m_bc"] + 2 * p["m_c"])


def potential_energy(theta, p):
    """V(theta) [J]: the weights (zero at the height of A) and the spring k (theta - rest)^2 / 2."""
    return weight_moment(p) * np.cos(theta) + 0.5 * p["k"] * (np.asarray(theta) - p["rest"]) ** 2


def generalized_gravity(theta, p):
    """dV/dtheta [N m] = -weight_moment sin(theta) + k (theta - rest)."""
    return -weight_moment(p) * np.sin(theta) + p["k"] * (np.asarray(theta) - p["rest"])


def omega_squared(theta, p):
    """omega^2 [rad^2/s^2] at ``theta`` on the motion started at (p["theta0"], p["omega0"])."""
    th0 = p["theta0"]
    energy = 0.5 * reduced_mass(th0, p) * p["omega0"] ** 2 + potential_energy(th0, p)
    return 2.0 * (energy - potential_energy(theta, p)) / reduced_mass(theta, p)


def book_omega_squared(theta, m, m_C, l, k, g):
    """The book's printed omega^2 (slender bars, released from rest at theta = 0, spring relaxed at 0)."""
    s, c = np.sin(theta), np.cos(theta)
    return (2 * g * l * (m + m_C) * (1 - c) - 0.5 * k * np.asarray(theta) ** 2) / (
        m * l**2 / 3 + (m + 2 * m_C) * l**2 * s**2
    )


def on_the_loop(theta, omega, p):
    """The full state on the loop: ({joint: q}, {joint: v}) for joint_a, joint_b, guide."""
    l = p["l"]
    q = {"joint_a": theta, "joint_b": -2 * theta, "guide": 2 * l * np.cos(theta)}
    v = {"joint_a": omega, "joint_b": -2 * omega, "guide": -2 * l * np.sin(theta) * omega}
    return q, v


def _z(element):
    return float(element.find("origin").get("xyz").split()[2])


def urdf_parameters(urdf):
    """m_ab, m_bc, m_c [kg], I_ab, I_bc [kg m^2] (about the centres, axis y), l [m] from ``linkage.urdf``.

    Raises ValueError when the bars are not of one length l with their centres at l / 2, which
    the closed form assumes (the collar then stays on the vertical through A).
    """
    root = ET.parse(urdf).getroot()
    links = {link.get("name"): link for link in root.findall("link")}
    joints = {joint.get("name"): joint for joint in root.findall("joint")}
    l_ab, l_bc = _z(joints["joint_b"]), _z(joints["bc_tip_joint"])
    if l_ab != l_bc:
        raise ValueError(f"{urdf}: bars AB ({l_ab} m) and BC ({l_bc} m) must be equally long")
    for name in ("bar_ab", "bar_bc"):
        if _z(links[name].find("inertial")) != l_ab / 2:
            raise ValueError(f"{urdf}: {name}'s centre of mass must be at l / 2 = {l_ab / 2} m")
    mass = {
        name: float(link.find("inertial/mass").get("value"))
        for name, link in links.items()
        if link.find("inertial") is not None
    }
    iyy = {name: float(links[name].find("inertial/inertia").get("iyy")) for name in ("bar_ab", "bar_bc")}
    return {
        "m_ab": mass["bar_ab"],
        "m_bc": mass["bar_bc"],
        "m_c": mass["collar"],
        "I_ab": iyy["bar_ab"],
        "I_bc": iyy["bar_bc"],
        "l": l_ab,
    }


def parameters(scene):
    """Everything the closed form needs: the URDF's, the spring's (k [N m/rad], rest [rad]) and the start."""
    scene = Path(scene)
    data = tomllib.loads(scene.read_text(encoding="utf-8"))
    params = urdf_parameters(scene.parent / data["model"]["urdf"])
    spring = data.get("springs", {}).get("joint_a", {})
    params["k"] = float(spring.get("stiffness", 0.0))
    params["rest"] = float(spring.get("rest", 0.0))
    initial = data.get("initial", {})
    params["theta0"] = float(initial.get("q", {}).get("joint_a", 0.0))
    params["omega0"] = float(initial.get("v", {}).get("joint_a", 0.0))
    params["g"] = GRAVITY
    return params


def closed_form(t, q: Mapping, v: Mapping, params):
    """omega^2 [rad^2/s^2] from energy conservation at the simulated theta."""
    return {"omega_squared": omega_squared(np.asarray(q["joint_a"]), params)}


def simulated(t, q: Mapping, v: Mapping, params):
    """The simulated omega^2 of joint_a."""
    return {"omega_squared": np.asarray(v["joint_a"]) ** 2}
