"""docs/parameters.md's controller parameter tables are the ones generated from the
dataclasses."""

from pathlib import Path

import pytest

from armando_drake.control import params_doc
from armando_drake.control.controllers.joint_trajectory import JointTrajectoryControllerParams

PAGE = Path(__file__).resolve().parents[2] / "docs" / "parameters.md"


def test_page_block_is_the_generated_text():
    text = PAGE.read_text(encoding="utf-8")
    start, end = text.index(params_doc.BEGIN), text.index(params_doc.END)
    assert text[start : end + len(params_doc.END)] == params_doc.render(), (
        "regenerate with: python -m armando_drake.control.params_doc --write docs/parameters.md"
    )


def test_rows_carry_ros_name_type_default_and_comment():
    rows = {row[0]: row[1:] for row in params_doc.parameter_rows(JointTrajectoryControllerParams)}
    assert rows["constraints.goal_time"] == (
        "float",
        "0.0",
        "[s] after the end to reach the goal; 0 = wait forever.",
    )
    assert rows["constraints.<joint>.trajectory"][:2] == ("float", "0.0")
    assert rows["gains.<joint>.p"] == ("float", "0.0", "[command unit/rad] proportional gain.")
    assert rows["interpolation_method"][1] == '"splines"'
    # Every field has its comment.
    assert all(meaning for _, _, meaning in rows.values())


def test_replace_block_needs_both_markers():
    with pytest.raises(ValueError, match="block"):
        params_doc.replace_block("no markers here", "x")
    text = f"a\n{params_doc.BEGIN}\nold\n{params_doc.END}\nb"
    assert params_doc.replace_block(text, "new") == "a\nnew\nb"
