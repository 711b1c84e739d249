"""Other engines' readings of a URDF (MuJoCo, PyBullet, Drake) compared with robodyn's: what differs and why.

No engine is imported here: each is imported by its own module when a comparison names it.
"""

from __future__ import annotations

from robodyn.other_engines.compare import against
from robodyn.other_engines.reading import ENGINES
from robodyn.other_engines.report import AgainstReport, Cause, Comparison, format_report

__all__ = ["ENGINES", "AgainstReport", "Cause", "Comparison", "against", "format_report"]
