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

import argparse
import shutil
import sys
from pathlib import Path

from armando_drake.tools.cli import UserError, add_scenario_arguments, command_parser, user_errors

# Drake and the world's modules load here; a Ctrl-C meanwhile exits 130, quietly.
with user_errors():
    from armando_drake.outputs.graph import FORMATS, INSTALL_HINT, graphviz_source, render
    from armando_drake.simulation.builder import MakeWorld
    from armando_drake.simulation.scenario import (
        apply_scenario_arguments,
        load_scenario,
        resolve_scenario_path,
    )


def _parser() -> argparse.ArgumentParser:
    parser = command_parser("armando_drake.graph", __doc__)
    add_scenario_arguments(parser)
    parser.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="FILE",
        help="where to write the graph: .svg, .png, .pdf, or .dot for the Graphviz source",
    )
    parser.add_argument(
        "--max-depth",
        type=int,
        default=1,
        metavar="N",
        help="how many levels of nested diagrams to open (default: 1, the world's systems)",
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    with user_errors():
        output = Path(args.output)
        if output.suffix.lower() not in FORMATS:
            render("", output)  # raises the unknown-extension error
        if FORMATS[output.suffix.lower()] is not None and shutil.which("dot") is None:
            raise UserError(f"Graphviz's dot is not on the PATH: {INSTALL_HINT}")
        if args.max_depth < 1:
            raise UserError(f"--max-depth {args.max_depth} must be at least 1")
        path = resolve_scenario_path(args.scenario)
        scenario = apply_scenario_arguments(load_scenario(path), args)
        world = MakeWorld(scenario, quiet=True, source=str(path))
        try:
            render(graphviz_source(world.diagram, args.max_depth), output)
        finally:
            world.close()
        names = [system.get_name() for system in world.diagram.GetSystems()]
        print(f"{output}: {len(names)} systems ({', '.join(names)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
