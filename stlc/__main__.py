"""``python -m stlc``: the command line (``stlc.cli.main``)."""

import sys

from stlc.cli import main

sys.exit(main())
