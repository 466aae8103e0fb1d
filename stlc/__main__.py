import sys

from stlc.cli import main

sys.exit(main())
