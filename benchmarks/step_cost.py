"""Per-step cost of the time-stepper: ``python benchmarks/step_cost.py [--quick]``.

The same as ``tumblemc bench``; kept here so benchmarks live apart from the tests.
"""

import sys

from tumblemc.stepcost import main

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
