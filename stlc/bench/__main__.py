"""``python -m stlc.bench monitor | compile FILE | suite``."""

import sys

from stlc.bench import main

sys.exit(main())
