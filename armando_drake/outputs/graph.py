"""Draws the world diagram: its systems and their named connections (the rqt_graph step).

Builds the world of a scenario with the same builder as ``python -m
armando_drake.world`` (without Meshcat), takes Drake's Graphviz description
of the diagram (``Diagram.GetGraphvizString``) and renders it with
Graphviz's ``dot`` to SVG or PNG (chosen by the output's extension; ``.dot``
writes the Graphviz source itself). Each box is a system with its named input
ports on the left and output ports on the right; each arrow is a connection.

Needs Graphviz's ``dot`` on the PATH; to install it on Debian/Ubuntu:
``apt-get install graphviz``.

Examples:
  python -m armando_drake.graph -o world.svg
  python -m armando_drake.graph --scenario trajectory -o trajectory.png
  python -m armando_drake.graph --set "camera: {enabled: true}" -o camera.svg
  python -m armando_drake.graph --max-depth 2 -o nested.svg   # open sub-diagrams too
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

from armando_drake.tools.cli import UserError

FORMATS = {".svg": "svg", ".png": "png", ".pdf": "pdf", ".dot": None, ".gv": None}
INSTALL_HINT = "install Graphviz (Debian/Ubuntu: apt-get install graphviz)"


def graphviz_source(diagram, max_depth: int = 1) -> str:
    """Drake's Graphviz (dot language) description of ``diagram``."""
    return diagram.GetGraphvizString(max_depth=max_depth)


def render(source: str, output: Path, dot: str | None = None) -> None:
    """Writes ``source`` (dot language) to ``output`` in the format its extension names.

    Raises UserError when the extension is unknown, ``dot`` is missing or fails.
    """
    suffix = output.suffix.lower()
    if suffix not in FORMATS:
        raise UserError(
            f"-o {output}: unknown extension {suffix or '(none)'!r}; use one of "
            + ", ".join(FORMATS)
        )
    if FORMATS[suffix] is None:
        _write(output, source.encode())
        return
    dot = dot or shutil.which("dot")
    if dot is None:
        raise UserError(f"Graphviz's dot is not on the PATH: {INSTALL_HINT}")
    result = subprocess.run(
        [dot, f"-T{FORMATS[suffix]}"], input=source.encode(), capture_output=True, check=False
    )
    if result.returncode != 0:
        message = " ".join(result.stderr.decode(errors="replace").split())
        raise UserError(f"dot failed (exit {result.returncode}): {message}")
    _write(output, result.stdout)


def _write(output: Path, data: bytes) -> None:
    try:
        output.write_bytes(data)
    except OSError as error:
        raise UserError(f"-o {output}: cannot write there: {error.strerror}") from None
