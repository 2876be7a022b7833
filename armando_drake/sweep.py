"""``python -m armando_drake.sweep``: the command of :mod:`armando_drake.sweeps.sweep`."""

import sys

from armando_drake.sweeps.sweep import main

if __name__ == "__main__":
    sys.exit(main())
