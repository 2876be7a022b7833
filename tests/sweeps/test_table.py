"""The results table and the figure, from made-up variant results (no world runs)."""

import csv

import pyarrow.parquet as pq
import pytest

from armando_drake.sweeps.errors import SweepError
from armando_drake.sweeps.plot import plot_sweep
from armando_drake.sweeps.table import ResultsTable, flatten, metrics, row
from armando_drake.sweeps.variant import VariantResult


def summary(errors, settles):
    return {
        "scenario": "position",
        "sim_time": 4.0,
        "interrupted": False,
        "tracking_error": None,
        "joint_names": ["j0"],
        "steps": [
            {"target": [0.5], "final_error": e, "settling_time": s, "start": 3.0 * i}
            for i, (e, s) in enumerate(zip(errors, settles, strict=True))
        ],
    }


def result(index, status="ok", summary_=None, error=""):
    return VariantResult(
        index=index,
        status=status,
        exit_code=0 if status == "ok" else 2,
        error=error,
        wall_time=2.0 + index,
        summary=summary_,
        host="here",
        command=[],
    )


def test_flatten_keeps_numbers_booleans_and_nulls_by_path():
    flat = flatten(summary([0.1, 0.02], [0.5, None]), "summary")
    assert flat["summary.sim_time"] == 4.0
    assert flat["summary.interrupted"] is False
    assert flat["summary.tracking_error"] is None
    assert flat["summary.steps.1.final_error"] == 0.02
    assert flat["summary.steps.1.target.0"] == 0.5
    assert "summary.scenario" not in flat and "summary.joint_names.0" not in flat


def test_metrics_of_the_steps():
    assert metrics(summary([0.1, 0.02], [0.5, 1.25])) == {
        "max_error": 0.1,
        "final_error": 0.02,
        "settle_time": 1.25,
    }
    # A step that never settled leaves the longest settle time undefined.
    assert metrics(summary([0.1, 0.3], [0.5, None]))["settle_time"] is None
    assert metrics(None) == {"max_error": None, "final_error": None, "settle_time": None}


@pytest.fixture
def table():
    rows = [
        row({"a.kp": 4, "a.kd": 0.1}, result(0, summary_=summary([0.1, 0.02], [0.5, 1.0]))),
        row({"a.kp": 4, "a.kd": 0.4}, result(1, summary_=summary([0.2, 0.01], [0.5, None]))),
        row({"a.kp": 16, "a.kd": 0.1}, result(2, "failed", error="error: bad kp")),
        row({"a.kp": 16, "a.kd": 0.4}, result(3, summary_=summary([0.3, 0.03], [0.2, 0.4]))),
    ]
    return ResultsTable(reversed(rows))  # sorted back by variant


def test_table_columns_types_and_files(table, tmp_path):
    assert [r["variant"] for r in table.rows] == [0, 1, 2, 3]
    assert table.columns[:11] == [
        "variant",
        "a.kp",
        "a.kd",
        "status",
        "exit_code",
        "error",
        "wall_time",
        "host",
        "max_error",
        "final_error",
        "settle_time",
    ]
    assert table.types["a.kp"] == "int" and table.types["a.kd"] == "float"
    assert table.types["summary.interrupted"] == "bool"
    csv_path, parquet_path = table.write(tmp_path)
    rows = list(csv.DictReader(csv_path.open()))
    assert rows[2]["status"] == "failed" and rows[2]["error"] == "error: bad kp"
    assert rows[2]["summary.sim_time"] == "" and rows[1]["settle_time"] == ""
    stored = pq.read_table(parquet_path).to_pylist()
    assert stored[3]["summary.steps.1.final_error"] == 0.03
    assert stored[2]["max_error"] is None


def test_figure_files_and_a_bad_metric(table, tmp_path):
    heat = plot_sweep(table, ["a.kp", "a.kd"], "max_error", tmp_path / "heat.png")
    line = plot_sweep(table, ["a.kp"], "final_error", tmp_path / "line.png")
    assert heat.stat().st_size > 10_000 and line.stat().st_size > 10_000
    with pytest.raises(SweepError, match="'nope' is not a number column.*max_error"):
        plot_sweep(table, ["a.kp"], "nope", tmp_path / "x.png")
    with pytest.raises(SweepError, match="'error' is not a number column"):
        plot_sweep(table, ["a.kp"], "error", tmp_path / "x.png")


def test_a_numeric_axis_is_a_line_and_a_categorical_one_bars():
    """Numbers on the axis: one line through the medians; names (a planner, a file): one
    bar per name, as high as its metric, labelled with it, none for a failed one."""
    from armando_drake.sweeps.plot import draw_sweep

    planners = ["NavfnPlanner", "SmacPlanner2D", "ThetaStarPlanner"]
    rows = [
        row({"planner": name}, result(k, summary_=summary([error, 0.01], [0.5, 1.0])))
        for k, (name, error) in enumerate(zip(planners[:2], [0.1, 0.25], strict=True))
    ]
    rows.append(row({"planner": planners[2]}, result(2, "failed", error="error: no plugin")))
    categorical = ResultsTable(rows)
    (ax,) = draw_sweep(categorical, ["planner"], "max_error").axes
    heights = [patch.get_height() for patch in ax.patches]
    assert heights == pytest.approx([0.1, 0.25]) and not [
        line for line in ax.lines if len(line.get_xdata()) > 1
    ]
    assert [t.get_text() for t in ax.get_xticklabels()] == planners
    assert [t.get_text() for t in ax.texts] == ["0.1", "0.25"]  # the bars' labels
    numeric = ResultsTable(
        [row({"a.kp": kp}, result(k, summary_=summary([e, 0.0], [0.5, 1.0])))
         for k, (kp, e) in enumerate([(4, 0.3), (8, 0.2), (16, 0.1)])]
    )  # fmt: skip
    (ax,) = draw_sweep(numeric, ["a.kp"], "max_error").axes
    assert not ax.patches
    (line,) = ax.lines
    assert list(line.get_xdata()) == [4, 8, 16] and list(line.get_ydata()) == [0.3, 0.2, 0.1]
