"""notebooks/08_sweep runs top to bottom in short mode, as the other notebooks' tests run them.

Executed by nbclient in the ``python3`` kernel from the ``notebooks`` folder with
``ARMANDO_DRAKE_SHORT=1`` (a 2 x 2 gain grid, 4 s per run); a cell that raises
fails the test.
"""

import re

from conftest import run_notebook

from armando_drake import PROJECT_ROOT
from armando_drake.sweeps.table import read_table


def test_gain_sweep_notebook(monkeypatch):
    text, pictures = run_notebook("08_sweep", monkeypatch, timeout=180)
    assert pictures == 2  # the settle_time and max_error heat maps
    assert "4 variants, e.g." in text
    assert "--set 'actuators: {kp: 4, kd: 0.4}'" in text
    assert re.search(r"^4 variants: 4 ok, 0 failed in \S+ s on local pool", text, re.M)
    rows = re.findall(r"^\s+(\d+)\s+(\S+)\s+(\S+)\s+(\S+)$", text, re.M)
    assert [(kp, kd) for kp, kd, _, _ in rows] == [
        ("4", "0.1"),
        ("4", "0.4"),
        ("16", "0.1"),
        ("16", "0.4"),
    ]
    # The printed errors are the table's, which the notebook wrote where it says.
    folder = PROJECT_ROOT / "out" / "notebooks" / "08_sweep"
    stored = read_table(folder).to_pylist()
    assert [f"{r['max_error']:.3g}" for r in stored] == [error for _, _, error, _ in rows]
    assert all(r["max_error"] > 0 for r in stored)  # the second target is on its way
    for metric in ("settle_time", "max_error"):
        assert (folder / f"{metric}.png").stat().st_size > 10_000
    assert re.search(r"^results.parquet: 4 rows, \d+ columns$", text, re.M)
