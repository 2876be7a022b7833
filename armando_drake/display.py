"""Shows a robot description in Meshcat with one slider per joint.

The equivalent of the course's ``display.launch`` (robot_state_publisher,
joint_state_publisher_gui and rviz2): opens Meshcat, prints its URL, draws the
robot with its visual and collision geometry as separate layers (toggle them
under Scene > drake in the Meshcat controls), one slider per joint, and the
view saved in ``diagrams/display.yaml``. Runs until Ctrl-C or the
"Stop Running" button.

Examples:
  python -m armando_drake.display
  python -m armando_drake.display --position 0.5 -0.8 1.0 0.3 --show-collision
  python -m armando_drake.display --description ../shared/upstream/arm_description
  python -m armando_drake.display --xacro-arg prefix:=left_ --loop-once
"""

from __future__ import annotations

import argparse
import logging
import sys

from armando_drake import DEFAULT_DESCRIPTION, DIAGRAMS_DIR
from armando_drake.tools.cli import (
    add_description_arguments,
    add_host_argument,
    command_parser,
    meshcat_urls,
    parse_xacro_args,
    start_meshcat,
    user_errors,
)

# Drake and the viewer load here; a Ctrl-C meanwhile exits 130, quietly.
with user_errors():
    from armando_drake.description.viewer import load_view_config, make_display


def _parser() -> argparse.ArgumentParser:
    parser = command_parser("armando_drake.display", __doc__)
    add_description_arguments(
        parser, default=str(DEFAULT_DESCRIPTION.relative_to(DIAGRAMS_DIR.parent))
    )
    parser.add_argument(
        "--position",
        nargs="+",
        type=float,
        metavar="Q",
        help="initial joint positions [rad], one per joint (e.g. 0 0 0 0 for Armando)",
    )
    parser.add_argument(
        "--view",
        default=str(DIAGRAMS_DIR / "display.yaml"),
        metavar="FILE",
        help="view preset: camera position and target, visible layers "
        "(default: diagrams/display.yaml)",
    )
    parser.add_argument(
        "--show-collision", action="store_true", help="show the collision geometry layer"
    )
    parser.add_argument(
        "--show-frames", action="store_true", help="draw every link frame as a triad"
    )
    parser.add_argument(
        "--loop-once",
        action="store_true",
        help="build, publish once and exit 0 (for scripts and tests)",
    )
    add_host_argument(parser)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    with user_errors():
        view = load_view_config(args.view)
        view.show_collision |= args.show_collision
        view.show_frames |= args.show_frames
        meshcat = start_meshcat(args.host)
        visualizer, robot = make_display(
            args.description,
            xacro_args=parse_xacro_args(args.xacro_arg),
            package_paths=args.package_path,
            view=view,
            position=args.position,
            meshcat=meshcat,
        )
        joints = ", ".join(f"{j.name} [{j.lower:.2f}, {j.upper:.2f}]" for j in robot.joints)
        print(f"Showing {robot.name!r} from {robot.source}")
        print(f"Joints: {joints}")
        welded = ", ".join(
            weld.link + (f" (fixed to the world link by {weld.joint!r})" if weld.joint else "")
            for weld in robot.welds
        )
        print(f"Welded to the world: {welded}")
        for joint in robot.mimic_joints:
            print(
                f"Mimic: {joint.name} = {joint.mimic_multiplier:g} * {joint.mimic} "
                f"+ {joint.mimic_offset:g} (its slider is free here; the simulation couples it)"
            )
        print(f"Meshcat: {meshcat_urls(meshcat)}", flush=True)
        visualizer.Run(loop_once=args.loop_once)
    return 0


if __name__ == "__main__":
    sys.exit(main())
