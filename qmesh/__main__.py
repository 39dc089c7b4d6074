"""`python -m qmesh` runs the `qmesh` command line."""

import sys

from .cli import main

sys.exit(main())
