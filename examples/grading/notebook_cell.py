"""A notebook exercise graded by a hidden test cell, as nbgrader or Otter runs it (docs/guides/grading.md).

    python examples/grading/notebook_cell.py

The student's cells define the double pendulum's dynamics at the notebook's top level (here, this file's); the
hidden test cell at the end grades them with robodyn.grade.notebook_check, exactly as ``robodyn grade`` grades a
file. This student dropped l1*lc2*cos(q2) from M[0,1].
"""

import math
from pathlib import Path

import numpy as np

from robodyn.grade import notebook_check

# ---- the student's cells ----------------------------------------------------------------------
KIND = "any"
JOINTS = ["shoulder", "elbow"]
COORDINATES = {"shoulder": (1.0, math.pi / 2), "elbow": (-1.0, 0.0)}  # theta1 from the downward vertical


def parameters(robot):
    upper, lower = robot["shoulder"], robot["elbow"]
    return {
        "m1": upper.mass,
        "m2": lower.mass,
        "l1": lower.origin[0],
        "lc1": upper.com[0],
        "lc2": lower.com[0],
        "I1": upper.inertia_about_axis,
        "I2": lower.inertia_about_axis,
        "g": robot.g,
    }


def mass_matrix(q, p):
    m1, m2, l1, lc1, lc2, I1, I2 = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "I1", "I2"))
    c2 = np.cos(q[1])
    m11 = m1 * lc1**2 + I1 + m2 * (l1**2 + lc2**2 + 2 * l1 * lc2 * c2) + I2
    m12 = m2 * lc2**2 + I2  # the slip: m2 * l1 * lc2 * c2 dropped
    m22 = m2 * lc2**2 + I2
    return np.array([[m11, m12], [m12, m22]])


def coriolis_matrix(q, v, p):
    h = -p["m2"] * p["l1"] * p["lc2"] * np.sin(q[1])
    return np.array([[h * v[1], h * (v[0] + v[1])], [-h * v[0], 0.0]])


def gravity(q, p):
    m1, m2, l1, lc1, lc2, g = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "g"))
    g2 = m2 * g * lc2 * np.sin(q[0] + q[1])
    return np.array([(m1 * lc1 + m2 * l1) * g * np.sin(q[0]) + g2, g2])


def potential_energy(q, p):
    m1, m2, l1, lc1, lc2, g = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "g"))
    return -m1 * g * lc1 * np.cos(q[0]) - m2 * g * (l1 * np.cos(q[0]) + lc2 * np.cos(q[0] + q[1]))


# ---- the hidden test cell ---------------------------------------------------------------------
ASSIGNMENT = Path(__file__).with_name("double_pendulum") / "assignment.toml"  # in a notebook: the path beside it
result = notebook_check(ASSIGNMENT, globals(), student="notebook")
print(result.feedback, end="")
print(f"points: {result.score:g} of {result.max_score:g}; full marks: {result.passed}")
