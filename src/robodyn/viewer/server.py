"""The live meshcat server: started as a child process on 127.0.0.1 (or one already running), fed over ZeroMQ.

:func:`serve` sends a playback's packed commands, once, to a meshcat server and returns a
:class:`Server` (its page's ``url``, :meth:`Server.wait`, :meth:`Server.close`). The server
robodyn starts is ``python -m robodyn.viewer`` (:func:`run_server` in the child): meshcat's
ZeroMQ-to-WebSocket bridge, which stops by itself when its parent dies.
"""

from __future__ import annotations

import os
import select
import socket
import subprocess
import sys
import tempfile
import time
from typing import IO, TYPE_CHECKING, Any, cast

from robodyn.errors import InputError, UnavailableError
from robodyn.viewer.backend import import_meshcat
from robodyn.viewer.packing import packed_commands

if TYPE_CHECKING:
    from robodyn.viewer.playback import Playback

SERVER_START_TIMEOUT_S = 30.0
REPLY_TIMEOUT_MS = 30_000  # robodyn's own server: big meshes take a while to pass through
CONNECT_TIMEOUT_MS = 10_000  # a server named by zmq_url: how long to wait for its first answer


class _Client:
    """A ZeroMQ request socket speaking meshcat's protocol, with timeouts."""

    def __init__(self, zmq_url: str, *, timeout_ms: int = REPLY_TIMEOUT_MS) -> None:
        import_meshcat()
        import zmq

        self.url = zmq_url
        self.timeout_ms = timeout_ms
        self.socket: Any = zmq.Context.instance().socket(zmq.REQ)
        self.socket.setsockopt(zmq.LINGER, 0)
        self.socket.setsockopt(zmq.RCVTIMEO, timeout_ms)
        self.socket.setsockopt(zmq.SNDTIMEO, timeout_ms)
        try:
            self.socket.connect(zmq_url)
        except zmq.ZMQError as exc:
            self.socket.close()
            raise InputError(f"bad --zmq-url {zmq_url!r} ({exc}); expected e.g. tcp://127.0.0.1:6000") from None

    def _request(self, frames: list[bytes]) -> bytes:
        import zmq

        try:
            self.socket.send_multipart(frames)
            return bytes(self.socket.recv())
        except zmq.Again:
            raise UnavailableError(
                f"no meshcat server answered at {self.url} within {self.timeout_ms / 1000:g} s "
                "(start one with meshcat-server, or leave out --zmq-url to let robodyn start its own)"
            ) from None

    def web_url(self) -> str:
        return self._request([b"url"]).decode("utf-8")

    def send_playback(self, playback: Playback) -> None:
        for kind, path, data in packed_commands(playback):
            reply = self._request([kind.encode(), path.encode(), data])
            if reply != b"ok":
                raise UnavailableError(f"the meshcat server at {self.url} refused a {kind} command: {reply!r}")

    def close(self) -> None:
        self.socket.close()


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _check_port_free(port: int) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(("127.0.0.1", port))
        except OSError as exc:
            raise UnavailableError(
                f"port {port} on 127.0.0.1 is in use ({exc.strerror}); pick another --port or leave it out"
            ) from None


class Server:
    """A meshcat server showing a :class:`Playback`: started by robodyn, or one already running.

    Use as a context manager, or call :meth:`close`; ``url`` is the page to open.
    """

    def __init__(self, process: subprocess.Popen[bytes] | None, client: _Client, url: str, log: Any) -> None:
        self.process = process
        self.client = client
        self.url = url
        self._log = log

    @property
    def owned(self) -> bool:
        """True when robodyn started this server (and stops it on :meth:`close`)."""
        return self.process is not None

    def wait(self) -> int:
        """Block until the server process ends (Ctrl-C raises KeyboardInterrupt); return its exit code."""
        if self.process is None:
            return 0
        return int(self.process.wait())

    def close(self) -> None:
        """Disconnect; stop the server if robodyn started it (SIGTERM, then SIGKILL after 5 s)."""
        self.client.close()
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        if self._log is not None:
            self._log.close()
            self._log = None

    def __enter__(self) -> Server:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def serve(playback: Playback, *, zmq_url: str | None = None, port: int | None = None) -> Server:
    """Show ``playback`` in a meshcat server and return it (the animation is sent once).

    Args:
        playback: what to show.
        zmq_url: a running meshcat server's ZeroMQ address (e.g. ``tcp://127.0.0.1:6000``);
            None starts a new server on 127.0.0.1.
        port: the web port of the new server (default: a free one).

    Raises:
        UnavailableError: ``port`` is in use, the server does not start, or nobody answers at ``zmq_url``.
    """
    if zmq_url is not None:
        client = _Client(zmq_url, timeout_ms=CONNECT_TIMEOUT_MS)
        try:
            url = client.web_url()
            client.send_playback(playback)
        except BaseException:
            client.close()
            raise
        return Server(None, client, url, None)
    process, zmq_address, url, log = _start_server(port)
    client = _Client(zmq_address)
    server = Server(process, client, url, log)
    try:
        client.send_playback(playback)
    except BaseException:
        server.close()
        raise
    return server


def _start_server(port: int | None) -> tuple[subprocess.Popen[bytes], str, str, Any]:
    import_meshcat()
    web_port = free_port() if port is None else port
    _check_port_free(web_port)
    zmq_port = free_port()
    log = tempfile.TemporaryFile()
    command = [sys.executable, "-u", "-m", "robodyn.viewer", "--zmq-port", str(zmq_port), "--port", str(web_port)]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=log, start_new_session=True)
    lines: list[str] = []
    deadline = time.monotonic() + SERVER_START_TIMEOUT_S
    stdout = cast(IO[bytes], process.stdout)  # stdout=PIPE above
    while len(lines) < 2 and time.monotonic() < deadline:
        ready, _, _ = select.select([stdout], [], [], 0.2)
        if ready:
            line = stdout.readline().decode("utf-8", "replace").strip()
            if line:
                lines.append(line)
            elif process.poll() is not None:
                break
        elif process.poll() is not None:
            break
    urls = dict(line.split("=", 1) for line in lines if "=" in line)
    if "zmq_url" not in urls or "web_url" not in urls:
        if process.poll() is None:
            process.kill()
        process.wait()
        log.seek(0)
        last = [x for x in log.read().decode("utf-8", "replace").splitlines() if x.strip()]
        log.close()
        reason = last[-1] if last else f"no answer within {SERVER_START_TIMEOUT_S:g} s"
        if "in use" in reason.lower():
            raise UnavailableError(f"port {web_port} on 127.0.0.1 is in use; pick another --port or leave it out")
        raise UnavailableError(f"the meshcat server did not start: {reason}")
    stdout.close()
    return process, urls["zmq_url"], urls["web_url"], log


def run_server(zmq_port: int, web_port: int) -> None:
    """Entry point of the server process: meshcat's bridge on 127.0.0.1, stopping with its parent.

    Prints ``zmq_url=...`` and ``web_url=...`` (what :func:`serve` waits for), then runs until
    interrupted or until its parent process is gone.
    """
    from meshcat.servers.zmqserver import ZMQWebSocketBridge
    from tornado.ioloop import PeriodicCallback

    bridge = ZMQWebSocketBridge(zmq_url=f"tcp://127.0.0.1:{zmq_port}", host="127.0.0.1", port=web_port)
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    parent = os.getppid()

    def stop_if_orphaned() -> None:
        if os.getppid() != parent:
            bridge.ioloop.stop()

    PeriodicCallback(stop_if_orphaned, 1000).start()
    try:
        bridge.run()
    except KeyboardInterrupt:
        pass
