"""``python -m tumblemc``: the command line."""

import sys

from tumblemc.cli import main

sys.exit(main())
