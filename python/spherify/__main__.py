"""``python -m spherify`` runs the command line (see :mod:`spherify.cli`)."""

import sys

from .cli import main

sys.exit(main())
