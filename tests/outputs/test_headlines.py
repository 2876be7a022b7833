"""The chapter figures on the terminal (outputs/headlines.py): each kind of run prints the
numbers its chapter is about, the same as summary.json's; and writes only the plots that
apply to it (outputs/plots.py)."""

import contextlib
import io
import json
import math
import re

import pytest

from armando_drake.outputs.headlines import chapter_lines
from armando_drake.world import main


def _run(tmp_path, *argv: str) -> tuple[list[str], dict]:
    """The lines a run prints after its headline, and its summary.json."""
    out = tmp_path / "out"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = main([*argv, "--no-meshcat", "--realtime-rate", "0", "--no-replay",
                     "--output", str(out)])  # fmt: skip
    assert code == 0, printed.getvalue()
    text = printed.getvalue()
    after = text.split(" simulated in ", 1)[1].splitlines()[1:]
    return after, json.loads((out / "summary.json").read_text())


def _plots(folder) -> set[str]:
    return {path.name for path in folder.glob("*.png")}


def _line(lines: list[str], prefix: str) -> str:
    (line,) = [line for line in lines if line.startswith(prefix)]
    return line


def _numbers(line: str) -> list[float]:
    return [float(n) for n in re.findall(r"[-+]?\d+\.\d+|[-+]?\d+", line)]


def test_the_meeting_arms_tool_points_end_within_a_millimetre(tmp_path):
    lines, summary = _run(tmp_path, "--scenario", "dual_armando_meet")
    line = _line(lines, "tool points:")
    assert "left's (crawer_base) and right's (crawer_base)" in line, line
    distance_mm = _numbers(line.split(")")[-1])[0]
    assert distance_mm < 1.0, line
    left, right = (summary["robots"][n]["end_effector"] for n in ("left", "right"))
    assert left["point"] == [0.0, 0.015, 0.064]
    # The shared point of the scenario: (0, 0, 0.30) m midway between the bases.
    assert math.dist(left["position"], [0.0, 0.0, 0.30]) < 0.003
    for arm in ("left", "right"):  # commanded arms: positions against their commands
        expected = {"positions.png", "tracking_error.png", "efforts.png"}
        assert _plots(tmp_path / "out" / arm) == expected
    assert distance_mm == pytest.approx(
        1e3 * math.dist(left["position"], right["position"]), abs=0.05
    )


def test_a_cmd_vel_run_prints_its_base_pose_and_odometry_drift(tmp_path):
    lines, summary = _run(tmp_path, "--scenario", "fra2mo", "--duration", "3")
    line = _line(lines, "base:")
    base = summary["base"]
    x, y, yaw, driven, drift, percent, heading = _numbers(line)
    assert (x, y) == (round(base["final_pose"]["x"], 3), round(base["final_pose"]["y"], 3))
    assert x > 0.3 and driven == round(base["distance_travelled"], 2)
    assert drift == round(base["odometry_drift"]["final_position"], 3)
    assert percent == pytest.approx(100 * drift / base["distance_travelled"], abs=0.1)
    # The base's path and speeds; its wheels' torques; no wheel angles, nothing commanded.
    assert _plots(tmp_path / "out") == {"base_path.png", "base_velocity.png", "efforts.png"}


def test_an_amcl_run_prints_its_localisation_error_over_time(tmp_path):
    lines, summary = _run(tmp_path, "--scenario", "fra2mo_amcl", "--duration", "8.5")
    line = _line(lines, "AMCL:")
    localization = summary["navigation"]["localization"]
    errors = localization["errors"]
    first, settled, last = _numbers(line)[0], _numbers(line)[2], _numbers(line)[-1]
    assert first == round(errors[0]["position"], 3) and last == round(errors[-1]["position"], 3)
    assert settled == round(localization["max_position_error_settled"], 3)
    assert settled < 0.05 < first, line  # converged from its first estimate
    assert _line(lines, "goals:").startswith("goals: 1/4 reached")


def test_a_perception_run_prints_its_plane_and_clusters(tmp_path):
    lines, summary = _run(tmp_path, "--scenario", "perception", "--duration", "1")
    line = _line(lines, "perception (world frame")
    perception = summary["perception"]
    (plane,) = perception["planes"]
    assert abs(plane["coefficients"][2]) > 0.99  # the table's top, level
    assert f"{len(perception['clusters'])} clusters" in line and len(perception["clusters"]) == 3
    for cluster in perception["clusters"]:
        assert f"{cluster['count']} points at" in line
    # An arm held still by no controller: only the torques holding it.
    assert _plots(tmp_path / "out") == {"efforts.png"}


def test_chapter_lines_of_an_exploration_and_of_goals():
    mapping = {"precision": 1.0, "recall": 0.98347, "coverage": 0.999, "frontier_goals": 4,
               "frontiers_left": 0, "done_at": 30.5, "slam_position_error": 0.0132,
               "odometry_position_error": 0.1186}  # fmt: skip
    (line,) = chapter_lines({"navigation": {"mapping": mapping, "goals": []}})
    assert line == (
        "map: precision 1.000, recall 0.983, coverage 0.999 of the world's free area; "
        "4 frontiers visited, 0 left, done at 30.5 s; pose error 0.013 m with SLAM, "
        "0.119 m on odometry alone"
    )
    goals = [
        {"name": "a", "reached": True, "position_error": 0.05, "yaw_error": 0.1},
        {"name": "b", "reached": False, "position_error": 1.0, "yaw_error": 0.0},
    ]
    (line,) = chapter_lines({"navigation": {"goals": goals, "collisions": 1}})
    assert (
        line
        == "goals: 1/2 reached, largest errors 0.050 m and 0.100 rad, not reached: b, 1 collisions"
    )


def test_tool_points_apart_in_millimetres_or_metres():
    robots = {
        "a": {"end_effector": {"frame": "tool", "position": [0.0, 0.0, 0.3]}},
        "b": {"end_effector": {"frame": "tool", "position": [0.0, 0.0004, 0.3]}},
        "c": {"end_effector": {"frame": "tool", "position": [1.25, 0.0, 0.3]}},
        "base": {"end_effector": None},  # a mobile base has none
    }
    (line,) = chapter_lines({"robots": robots})
    assert line == (
        "tool points: a's (tool) and b's (tool) 0.4 mm apart; "
        "a's (tool) and c's (tool) 1.250 m apart; b's (tool) and c's (tool) 1.250 m apart"
    )


def test_two_welded_wheeled_robots_report_no_tool_point(tmp_path):
    """fra2mo welded (base: fixed): its last joints are wheels (continuous), so no tool
    point is reported or printed, as for a free mobile base."""
    robots = "".join(
        f"  - name: {name}\n    robot:\n      description: "
        "package://fra2mo_description/urdf/fra2mo.urdf.xacro\n"
        f"      base_xyz: [0.0, {y}, 0.1]\n      base: fixed\n"
        "    controllers:\n      activate: [joint_state_broadcaster]\n"
        for name, y in (("a", -0.5), ("b", 0.5))
    )
    path = tmp_path / "welded.yaml"
    path.write_text(f"robots:\n{robots}simulation: {{duration: 0.2}}\n")
    lines, summary = _run(tmp_path, "--scenario", str(path))
    assert [summary["robots"][n]["end_effector"] for n in ("a", "b")] == [None, None]
    assert not [line for line in lines if line.startswith("tool points:")], lines
