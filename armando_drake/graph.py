"""``python -m armando_drake.graph``: the command of :mod:`armando_drake.outputs.graph`."""

import sys

from armando_drake.outputs.graph import main

if __name__ == "__main__":
    sys.exit(main())
