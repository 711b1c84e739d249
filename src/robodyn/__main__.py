"""``python -m robodyn`` runs the command line."""

import sys

from robodyn.cli import main

sys.exit(main())
