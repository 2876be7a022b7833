"""The world diagram as a graph: Drake's Graphviz description of a diagram
(``Diagram.GetGraphvizString``) rendered with Graphviz's ``dot`` to SVG, PNG or PDF (by the
output's extension; ``.dot`` writes the source itself). The command is
:mod:`armando_drake.graph` (``python -m armando_drake.graph -o world.svg``)."""

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
