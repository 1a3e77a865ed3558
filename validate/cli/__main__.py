"""`python -m lagrange_xval.cli`: the command line."""

import sys

from . import main

sys.exit(main())
