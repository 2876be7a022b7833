"""``python -m armando_drake.plots`` on a garbled ``base.csv``: one line naming the file and
the line, exit 2, no traceback; a last line cut short (a killed run) is left out."""

import subprocess
import sys
from pathlib import Path

from armando_drake.outputs.base import COLUMNS

REPO = Path(__file__).resolve().parents[2]


def _folder(tmp_path: Path, rows: list[str]) -> Path:
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "joint_states.csv").write_text(
        "time,wheel_position,wheel_velocity,wheel_effort\n0.0,0,0,0\n0.1,0.1,1,0\n0.2,0.2,1,0\n"
    )
    (folder / "base.csv").write_text(",".join(COLUMNS) + "\n" + "\n".join(rows))
    return folder


def _row(t: float, x: str = "0.5") -> str:
    values = [str(t), x] + ["0.0"] * (len(COLUMNS) - 2)
    return ",".join(values)


def _plots(folder: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "armando_drake.plots", str(folder)],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=300,
    )


def test_a_value_that_is_no_number_names_the_file_and_line(tmp_path):
    folder = _folder(tmp_path, [_row(0.0), _row(0.1), _row(0.2, "abc"), _row(0.3), ""])
    result = _plots(folder)
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"error: {folder / 'base.csv'}: line 4:"), lines[0]
    assert "abc" in lines[0]


def test_a_row_of_the_wrong_width_names_the_file_and_line(tmp_path):
    folder = _folder(tmp_path, [_row(0.0), "0.1,2,3", _row(0.2), ""])
    result = _plots(folder)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert result.stderr.strip() == (
        f"error: {folder / 'base.csv'}: line 3: 3 values, expected {len(COLUMNS)}"
    )


def test_a_last_line_cut_short_is_left_out(tmp_path):
    folder = _folder(tmp_path, [_row(0.0), _row(0.1), _row(0.2)[:9]])
    result = _plots(folder)
    assert result.returncode == 0, result.stderr
    assert (folder / "base_path.png").is_file()
