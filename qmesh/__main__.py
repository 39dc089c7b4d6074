"""`python -m qmesh` runs the `qmesh` command line."""

import sys

from qmesh.cli import main

sys.exit(main())
