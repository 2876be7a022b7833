"""``python -m armando_drake.plots``: the command of :mod:`armando_drake.outputs.plots`."""

import sys

from armando_drake.outputs.plots import main

if __name__ == "__main__":
    sys.exit(main())
