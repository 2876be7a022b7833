"""The docs' controller parameter tables are the ones generated from the dataclasses."""

import importlib.util
from pathlib import Path

import pytest

from armando_drake.control import params_doc
from armando_drake.control.controllers.joint_trajectory import JointTrajectoryControllerParams

HOOKS = Path(__file__).resolve().parents[2] / "docs" / "hooks.py"


def test_docs_page_is_the_generated_text():
    """The site's reference page (made by docs/hooks.py at each build) holds the block."""
    spec = importlib.util.spec_from_file_location("docs_hooks", HOOKS)
    hooks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hooks)
    page = hooks.controller_parameters_page()
    assert params_doc.render() in page
    assert "`joint_trajectory_controller/JointTrajectoryController`" in page


def test_rows_carry_ros_name_type_default_and_comment():
    rows = {row[0]: row[1:] for row in params_doc.parameter_rows(JointTrajectoryControllerParams)}
    assert rows["constraints.goal_time"] == (
        "float",
        "0.0",
        "[s], zero or positive",
        "[s] after the end to reach the goal; 0 = wait forever.",
    )
    assert rows["constraints.<joint>.trajectory"][:3] == ("float", "0.0", "[rad], zero or positive")
    assert rows["gains.<joint>.p"] == ("float", "0.0", "", "[command unit/rad] proportional gain.")
    assert rows["interpolation_method"][1:3] == ('"splines"', "one of `splines`, `none`")
    assert "required" in rows["command_interfaces"][2]
    # Every field has its comment.
    assert all(meaning for _, _, _, meaning in rows.values())


def test_replace_block_needs_both_markers():
    with pytest.raises(ValueError, match="block"):
        params_doc.replace_block("no markers here", "x")
    text = f"a\n{params_doc.BEGIN}\nold\n{params_doc.END}\nb"
    assert params_doc.replace_block(text, "new") == "a\nnew\nb"
