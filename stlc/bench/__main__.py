"""``python -m stlc.bench monitor | compile FILE``."""

import sys

from stlc.bench.tables import main

sys.exit(main())
