"""The plots' titles name the run once, vision.png has one, and long joint names stay
legible: each beside its own panel, none running into another or into the tick labels."""

import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from armando_drake.outputs.plots import _joint_figure, plot_title
from armando_drake.vision.outputs import write_vision_plot


@pytest.mark.parametrize(
    "summary, title",
    [
        ({"scenario": "diagrams/position.yaml", "controller": "position"}, "position"),
        ({"scenario": "trajectory.yaml", "controller": "trajectory"}, "trajectory"),
        ({"scenario": "task_js.yaml", "controller": "task"}, "task_js"),
        ({"scenario": "vision_look_at.yaml", "controller": "vision"}, "vision_look_at"),
        ({"scenario": "ros2.yaml", "controller": "dds"}, "ros2 (dds)"),
        ({"scenario": "world.yaml", "controller": "position"}, "world (position)"),
        ({"scenario": "ros2.yaml", "controller": "none"}, "ros2 (no controller)"),
        ({}, "run1"),
    ],
)
def test_the_title_names_the_run_once(summary, title):
    assert plot_title(summary, "run1") == title


def _extent(artist, renderer):
    return artist.get_window_extent(renderer)


@pytest.mark.parametrize("count", [4, 7, 12])
def test_long_joint_names_do_not_overlap(count):
    joints = [f"left_arm_iiwa_joint_{k}" for k in range(1, count + 1)]
    fig, axes = _joint_figure("Joint positions", "rad", "task_js", joints, [0.0, 1.0])
    for axis in axes:
        axis.plot([0.0, 2.0], [-1.5, 1.5])
    canvas = FigureCanvasAgg(fig)  # as savefig draws it
    canvas.draw()
    renderer = canvas.get_renderer()
    assert fig.get_suptitle() == "Joint positions [rad]: task_js"
    labels = [_extent(axis.yaxis.label, renderer) for axis in axes]
    figure_box = fig.bbox
    for k, (axis, label) in enumerate(zip(axes, labels, strict=True)):
        assert axis.get_ylabel() == joints[k]
        assert label.x0 >= figure_box.x0 and label.x1 <= figure_box.x1, joints[k]
        ticks = [_extent(t, renderer) for t in axis.get_yticklabels() if t.get_text()]
        assert all(label.x1 <= tick.x0 + 0.5 for tick in ticks), joints[k]  # left of them
        for other in labels[k + 1 :]:
            assert not label.overlaps(other), joints[k]


def test_vision_png_has_a_title(tmp_path, monkeypatch):
    csv_path = tmp_path / "vision.csv"
    header = ["time", "s_x", "s_y", "s_z", "iiwa_joint_1_velocity_command"]
    rows = [[0.0, 0.4, 0.0, 0.9, -0.1], [0.1, 0.2, 0.0, 0.98, -0.05]]
    csv_path.write_text(
        ",".join(header) + "\n" + "\n".join(",".join(map(str, row)) for row in rows) + "\n"
    )
    saved = []
    monkeypatch.setattr(Figure, "savefig", lambda fig, path, **_: saved.append(fig))
    write_vision_plot(csv_path, tmp_path / "vision.png", "vision_look_at")
    write_vision_plot(csv_path, tmp_path / "vision.png")
    assert saved[0].get_suptitle() == (
        "Vision: joint velocity commands and the target's direction s: vision_look_at"
    )
    assert saved[1].get_suptitle().endswith(f": {tmp_path.name}")
