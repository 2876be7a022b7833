"""``python -m armando_drake.dataset``: the command of :mod:`armando_drake.sweeps.dataset`."""

import sys

from armando_drake.sweeps.dataset import main

if __name__ == "__main__":
    sys.exit(main())
