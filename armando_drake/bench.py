"""``python -m armando_drake.bench``: the command of :mod:`armando_drake.benchmarks.suite`."""

import sys

from armando_drake.benchmarks.suite import main

if __name__ == "__main__":
    sys.exit(main())
