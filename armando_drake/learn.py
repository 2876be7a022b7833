"""``python -m armando_drake.learn``: the command of :mod:`armando_drake.sweeps.learn`."""

import sys

from armando_drake.sweeps.learn import main

if __name__ == "__main__":
    sys.exit(main())
