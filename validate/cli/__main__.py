"""`python -m lagrange_xval.validate.cli`: the command line."""

import sys

from . import main

sys.exit(main())
