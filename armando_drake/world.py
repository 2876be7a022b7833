"""Runs the Armando world: robot, ros2_control controllers, command sequence, logs.

The project's main job, the course's arm_controller_node in Drake: loads a
scenario from diagrams/ (default: position.yaml, the course's five seed
targets 3 s apart through the position controller), shows it in Meshcat
paced to real time, prints the joint positions once a second, and ends with
a table per step: target, reached position, final error, largest error after
settling, settling time (within 0.01 rad). Ctrl-C stops cleanly and still
writes the table and the logs.

The viewer opens on the robot. On a terminal the run waits (up to 60 s,
--wait, --no-wait) for a browser to open the printed URL before the clock
starts, and after the run Meshcat keeps serving the run as an animation to
scrub until Ctrl-C (--exit-when-done exits at once); not on a terminal it
neither waits nor stays unless --wait / --keep-serving say so. Faster than
real time, a progress bar shows on a terminal.

With --output DIR it writes DIR/joint_states.csv (time, then position,
velocity, effort per joint, one row per controller tick), DIR/commands.csv
(time and commanded positions) and DIR/summary.json, plots of positions
against commands, tracking error and efforts (positions.png,
tracking_error.png, efforts.png), and DIR/replay.html, the run as a Meshcat
animation that plays offline in any browser (recorded by a private Meshcat
when --no-meshcat; --no-replay skips it). A scenario with a task: section
(task_js, task_os, task_armando) also gets DIR/task_space.csv, task_error.png,
joint_torques.png and task_path.png, and task_space errors in summary.json.

With --record FILE.mcap it records the run as a ROS 2 bag (MCAP storage,
CDR): /joint_states, the sequencer's commands (/position_controller/commands
or /trajectory_controller/joint_trajectory) and, with the camera on,
/camera/image_raw and /camera/camera_info, stamped with simulation time;
ros2 bag info/play and Foxglove open it.

Examples:
  python -m armando_drake.world
  python -m armando_drake.world --controller trajectory
  python -m armando_drake.world --no-wait --exit-when-done       # from a script
  python -m armando_drake.world --controller sinusoid --duration 40
  python -m armando_drake.world --no-meshcat --realtime-rate 0 --output out/run1
  python -m armando_drake.world --no-meshcat --realtime-rate 0 --record out/run1.mcap
  python -m armando_drake.world --scenario diagrams/world.yaml     # no controller: it falls
  python -m armando_drake.world --scenario camera --save-frames out/frames --save-rate 2
  python -m armando_drake.world --set "actuators: {kp: 4.0}" --set "sequencer: {period: 5}"
  python -m armando_drake.world --scenario sinusoid --set "sequencer: !Sinusoid {frequency: 0.1}"
  python -m armando_drake.world --scenario task_os --set "task: {path: circular, profile: cubic}"
"""

import signal
import sys

if __name__ == "__main__":  # Ctrl-C while the command starts: exit 130, quietly
    signal.signal(signal.SIGINT, lambda signum, frame: sys.exit(130))

from armando_drake.tools.cli import user_errors  # noqa: E402 (after the handler)

# Drake and the world's modules load here; a Ctrl-C meanwhile exits 130, quietly.
with user_errors():
    from armando_drake.simulation.command import run_command, world_parser


def main(argv: list[str] | None = None) -> int:
    return run_command(argv, __doc__)


def _parser():
    """The command's parser (its --help)."""
    return world_parser(__doc__)


if __name__ == "__main__":
    sys.exit(main())
