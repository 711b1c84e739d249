"""The meshcat server process that :func:`robodyn.viewer.serve` starts: ``python -m robodyn.viewer``."""

import argparse

from robodyn.viewer.server import run_server

_parser = argparse.ArgumentParser(prog="python -m robodyn.viewer", description="robodyn's meshcat server")
_parser.add_argument("--zmq-port", type=int, required=True)
_parser.add_argument("--port", type=int, required=True)
_args = _parser.parse_args()
run_server(_args.zmq_port, _args.port)
