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


# Headless Chromium with no network of its own and WebGL in software (SwiftShader): the flags
# every browser test starts it with.
HEADLESS_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--enable-unsafe-swiftshader",
    "--use-angle=swiftshader",
)


class DevTools:
    """A headless Chromium driven over the DevTools protocol: load a page, evaluate JavaScript, click, photograph.

    Only the standard library and tornado (a dependency of meshcat) are used. Chromium is
    started on a blank page with ``--remote-debugging-port=0`` and prints the port it took;
    the page's websocket comes from ``/json/list``. :meth:`open` sets the viewport to exactly
    ``width`` x ``height`` CSS pixels (scale 1) and then loads the page, so that its layout is
    computed for that size. Use as a context manager: the browser is killed on exit.
    """

    def __init__(self, chromium: str, *, width: int, height: int, profile: Path) -> None:
        self.process = subprocess.Popen(
            [
                chromium,
                *HEADLESS_FLAGS,
                "--hide-scrollbars",
                f"--user-data-dir={profile}",
                f"--window-size={width},{height}",
                "--remote-debugging-port=0",
                "about:blank",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        self._id = 0
        self._socket = None
        self.width, self.height = width, height
        from tornado.ioloop import IOLoop

        self._loop = IOLoop(make_current=False)
        try:
            self._socket = self._loop.run_sync(self._connect, timeout=SERVER_WAIT_S)
        except BaseException:
            self.close()
            raise

    async def _connect(self):  # type: ignore[no-untyped-def]
        import asyncio
        import json
        import urllib.request

        from tornado.websocket import websocket_connect

        assert self.process.stderr is not None
        port = None
        while port is None:
            line = await asyncio.get_running_loop().run_in_executor(None, self.process.stderr.readline)
            if line == "":
                raise AssertionError("chromium ended before it printed its DevTools port")
            match = re.search(r"DevTools listening on ws://127\.0\.0\.1:(\d+)/", line)
            if match:
                port = int(match.group(1))
        for _ in range(200):
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10) as reply:
                pages = [p for p in json.loads(reply.read()) if p.get("type") == "page"]
            if pages:
                return await websocket_connect(pages[0]["webSocketDebuggerUrl"], max_message_size=1 << 28)
            await asyncio.sleep(0.1)
        raise AssertionError("chromium opened no page")

    def open(self, url: str) -> None:
        """Load ``url`` in a viewport of the size given and wait until the replay page says it is ready."""
        self.call(
            "Emulation.setDeviceMetricsOverride",
            width=self.width,
            height=self.height,
            deviceScaleFactor=1,
            mobile=False,
        )
        self.call("Page.navigate", url=url)
        self.wait_for("document.readyState === 'complete' && document.body.getAttribute('data-robodyn') === 'ready'")

    def call(self, method: str, **params: object) -> dict:  # type: ignore[type-arg]
        """Send one DevTools command and return its result (events in between are dropped)."""
        import json

        self._id += 1
        ident = self._id

        async def exchange() -> dict:  # type: ignore[type-arg]
            assert self._socket is not None
            await self._socket.write_message(json.dumps({"id": ident, "method": method, "params": params}))
            while True:
                message = await self._socket.read_message()
                if message is None:
                    raise AssertionError(f"the DevTools connection closed during {method}")
                reply = json.loads(message)
                if reply.get("id") == ident:
                    if "error" in reply:
                        raise AssertionError(f"{method}: {reply['error']}")
                    return reply["result"]

        return self._loop.run_sync(exchange, timeout=SERVER_WAIT_S)

    def evaluate(self, expression: str) -> object:
        """The value of a JavaScript expression in the page (JSON-serialisable values only)."""
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in result:
            raise AssertionError(f"{expression}: {result['exceptionDetails']}")
        return result["result"].get("value")

    def wait_for(self, expression: str) -> object:
        """Poll ``expression`` until it is truthy (SERVER_WAIT_S at most); return its value.

        An evaluation that fails (e.g. while a page loads, its context not there yet) counts as not yet.
        """
        deadline = time.monotonic() + SERVER_WAIT_S
        last = ""
        while time.monotonic() < deadline:
            try:
                value = self.evaluate(expression)
            except AssertionError as exc:
                value, last = None, str(exc)
            if value:
                return value
            time.sleep(0.1)
        raise AssertionError(f"the page never satisfied {expression} {last}")

    def click(self, x: float, y: float) -> None:
        """A left click (press and release) at viewport pixel (x, y)."""
        for kind in ("mousePressed", "mouseReleased"):
            self.call("Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left", clickCount=1)

    def screenshot(self, out: Path):  # type: ignore[no-untyped-def]
        """Save a PNG of the viewport to ``out`` and return it as an RGB array (H, W, 3)."""
        import base64
        import io

        import numpy as np
        from PIL import Image

        data = base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])
        out.write_bytes(data)
        return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))

    def close(self) -> None:
        """Close the connection and kill the browser."""
        if self._socket is not None:
            self._socket.close()
            self._socket = None
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()
        if self.process.stderr is not None:
            self.process.stderr.close()
        self._loop.close(all_fds=True)

    def __enter__(self) -> DevTools:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
