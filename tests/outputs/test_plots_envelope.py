"""Long runs are plotted through the envelope of their samples: bounded points, the same
peaks; the CSV reader takes numpy's parser and still skips a line cut short."""

import numpy as np

from armando_drake.outputs.logger import read_csv
from armando_drake.outputs.plots import envelope


def test_the_envelope_keeps_every_peak_with_a_bounded_number_of_points():
    rng = np.random.default_rng(7)
    m = 360_000  # an hour at 100 Hz
    values = np.column_stack([np.sin(np.arange(m) * 1e-3), rng.normal(size=m)])
    values[123_457, 0] = 5.0  # a spike a plain stride would step over
    values[200_001, 1] = -9.0
    values[50:60, 1] = np.nan
    shown = envelope(values, max_points=4000)
    assert len(shown) <= 2 * 4000 + 2
    assert shown[0] == 0 and shown[-1] == m - 1
    assert np.all(np.diff(shown) > 0)
    assert 123_457 in shown and 200_001 in shown
    for column in range(2):  # the drawn line reaches the same extremes
        assert np.nanmax(values[shown, column]) == np.nanmax(values[:, column])
        assert np.nanmin(values[shown, column]) == np.nanmin(values[:, column])


def test_a_short_series_is_drawn_whole():
    values = np.arange(30.0).reshape(10, 3)
    assert np.array_equal(envelope(values, max_points=4000), np.arange(10))


def test_read_csv_skips_a_last_line_cut_short(tmp_path):
    whole = tmp_path / "whole.csv"
    whole.write_text("time,a,b\n0.0,1,2\n0.01,3,nan\n")
    header, rows = read_csv(whole)
    assert header == ["time", "a", "b"]
    assert rows.shape == (2, 3) and rows[1, 1] == 3.0 and np.isnan(rows[1, 2])
    cut = tmp_path / "cut.csv"
    cut.write_text("time,a,b\n0.0,1,2\n0.01,3,4\n0.02,5")
    header, rows = read_csv(cut)
    assert rows.shape == (2, 3) and rows[-1, 0] == 0.01
    empty = tmp_path / "empty.csv"
    empty.write_text("time,a,b\n")
    assert read_csv(empty)[1].shape == (0, 3)
