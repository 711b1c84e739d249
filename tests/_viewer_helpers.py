"""Running ``robodyn view`` as a real process: shared by the viewer and browser tests."""

from __future__ import annotations

import contextlib
import re
import select
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

SERVER_WAIT_S = 60.0  # generous: the machine is shared; nothing here measures time


@contextlib.contextmanager
def view_process(trajectory_file: Path, port: int) -> Iterator[tuple[subprocess.Popen[str], str]]:
    """``python -m robodyn view pendubot FILE --port PORT`` and the URL it printed; killed on exit if still up."""
    process = subprocess.Popen(
        [sys.executable, "-m", "robodyn", "view", "pendubot", str(trajectory_file), "--port", str(port)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        yield process, wait_for_url(process)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


def interrupt(process: subprocess.Popen[str]) -> str:
    """Ctrl-C the process, wait for it to end and return its stderr."""
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=SERVER_WAIT_S)
    return err


def wait_for_url(process: subprocess.Popen[str]) -> str:
    """The URL of the ``meshcat: open URL`` line the process prints on stdout."""
    deadline = time.monotonic() + SERVER_WAIT_S
    assert process.stdout is not None
    while time.monotonic() < deadline:
        ready, _, _ = select.select([process.stdout], [], [], 0.5)
        if ready:
            line = process.stdout.readline()
            match = re.match(r"meshcat: open (\S+)", line)
            if match:
                return match.group(1)
            if line == "" and process.poll() is not None:
                break
    raise AssertionError(f"robodyn view printed no URL: {process.stderr.read() if process.stderr else ''}")


SLIDER_URDF = """<?xml version="1.0"?>
<robot name="slider">
  <link name="base"/>
  <joint name="rail" type="prismatic">
    <parent link="base"/>
    <child link="cart"/>
    <axis xyz="1 0 0"/>
    <limit lower="-1000" upper="1000" effort="200" velocity="1000"/>
  </joint>
  <link name="cart">
    <inertial><mass value="2"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><box size="0.5 0.3 0.25"/></geometry></visual>
  </link>
</robot>
"""
"""A box (0.5 m long) on a prismatic rail along x: the robot that travels far."""


def travel_trajectory(robot, *, distance: float = 100.0, duration: float = 2.0, force: float = 50.0):  # type: ignore[no-untyped-def]
    """The box pushed from rest by a constant ``force`` [N] so that it covers ``distance`` [m] in ``duration`` [s].

    The mass follows from the distance (x = F t^2 / 2 m); returns a Trajectory with its books.
    """
    import numpy as np

    from robodyn.sim.trajectory import Trajectory

    mass = float(robot.model.inertias[1].mass)
    accel = 2 * distance / duration**2
    t = np.linspace(0.0, duration, 201)
    x, v = 0.5 * accel * t**2, accel * t
    tau = np.full_like(t, mass * accel)
    kinetic = 0.5 * mass * v**2
    return Trajectory(
        t=t,
        q=x[:, None],
        v=v[:, None],
        a=np.full((len(t), 1), accel),
        tau=tau[:, None],
        kinetic=kinetic,
        potential=np.zeros_like(t),
        work_input=kinetic.copy(),
        work_damping=np.zeros_like(t),
        meta={"model": robot.name, "joint_names": list(robot.joint_names), "integrator": "exact"},
    )
