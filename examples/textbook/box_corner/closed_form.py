"""Example 6.1: the inertia tensor of a uniform box about its corner (Eq. 6.24), and a spin that needs all of it.

With the box filling [0, w] x [0, l] x [0, h] and rho = m / (w l h), Eq. (6.17) integrates to

    I_xx = m (l^2 + h^2) / 3,  I_yy = m (w^2 + h^2) / 3,  I_zz = m (l^2 + w^2) / 3   (6.18-6.20)
    I_xy = m w l / 4,          I_xz = m h w / 4,          I_yz = m h l / 4           (6.21-6.23)

(the book's products of inertia are +integral(x y dm)), and the tensor (6.16, 6.24) holds them
negated off the diagonal. About an axis u through the corner the moment of inertia is
I_u = u . I_A u; a constant couple Gamma about u spins the box up at omega(t) = omega0 + Gamma t / I_u
when gravity does no work (u vertical). Interface: see
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


def corner_tensor(m, w, l, h):
    """Eq. (6.24): the inertia tensor [kg m^2] about the corner, in axes along the edges."""
    return np.array(
        [
            [m * (l**2 + h**2) / 3, -m * w * l / 4, -m * h * w / 4],
            [-m * w * l / 4, m * (w**2 + h**2) / 3, -m * h * l / 4],
            [-m * h * w / 4, -m * h * l / 4, m * (l**2 + w**2) / 3],
        ]
    )


def axis_inertia(p):
    """I_u = u . I_A u [kg m^2] about the unit axis p["u"] through the corner."""
    u = np.asarray(p["u"], dtype=float)
    return float(u @ corner_tensor(p["m"], p["w"], p["l"], p["h"]) @ u)


def spin_rate(t, p):
    """omega(t) = omega0 + Gamma t / I_u [rad/s]."""
    return p["omega0"] + p["Gamma"] * (np.asarray(t) - p["t0"]) / axis_inertia(p)


def urdf_parameters(urdf):
    """m [kg], the box's (w, l, h) [m] and the spin axis u (unit, in the box's axes) from ``box.urdf``.

    Raises ValueError unless the box's corner is the link's origin (its geometry centred at
    (w/2, l/2, h/2), unrotated) and the inertial origin is the box's centre.
    """
    root = ET.parse(urdf).getroot()
    joint = root.find("joint[@name='spin']")
    link = root.find(f"link[@name='{joint.find('child').get('link')}']")
    w, l, h = (float(x) for x in link.find("visual/geometry/box").get("size").split())
    centre = [w / 2, l / 2, h / 2]
    for where in ("visual/origin", "inertial/origin"):
        origin = link.find(where)
        xyz = [float(x) for x in origin.get("xyz").split()]
        rpy = [float(x) for x in origin.get("rpy", "0 0 0").split()]
        if not np.allclose(xyz, centre, rtol=0, atol=1e-12) or any(rpy):
            raise ValueError(f"{urdf}: {where} must be the box's centre {centre} with rpy 0 0 0")
    u = np.array([float(x) for x in joint.find("axis").get("xyz").split()])
    return {
        "m": float(link.find("inertial/mass").get("value")),
        "w": w,
        "l": l,
        "h": h,
        "u": tuple(u / np.linalg.norm(u)),
    }


def parameters(scene):
    """The URDF's box and axis, the scene's couple Gamma [N m] on spin, and omega0 [rad/s]."""
    scene = Path(scene)
    data = tomllib.loads(scene.read_text(encoding="utf-8"))
    params = urdf_parameters(scene.parent / data["model"]["urdf"])
    params["Gamma"] = float(data["control"]["torque"]["spin"])
    params["omega0"] = float(data.get("initial", {}).get("v", {}).get("spin", 0.0))
    params["t0"] = 0.0
    return params


def closed_form(t, q: Mapping, v: Mapping, params):
    """omega(t) [rad/s]."""
    return {"omega": spin_rate(t, params)}


def simulated(t, q: Mapping, v: Mapping, params):
    """The simulated spin rate [rad/s]."""
    return {"omega": np.asarray(v["spin"])}
