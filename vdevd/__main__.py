"""`python -m vdevd` is `vdevd`."""

import sys

from vdevd.cli import main

sys.exit(main())
