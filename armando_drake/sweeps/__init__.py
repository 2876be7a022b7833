"""Many runs at once: parameter sweeps of the world and data sets, on one machine or a cluster.

- :mod:`~armando_drake.sweeps.axes`: the axes of a sweep (``--grid``, ``--random``) and
  the variants they make, each a set of scenario overrides;
- :mod:`~armando_drake.sweeps.variant`: one variant run as its own headless
  ``python -m armando_drake.world`` process, and what it left (summary, exit, error);
- :mod:`~armando_drake.sweeps.engines`: where tasks run: a local process pool or Ray;
- :mod:`~armando_drake.sweeps.table`: the results table (CSV and Parquet);
- :mod:`~armando_drake.sweeps.sweep`: the sweep itself, ``python -m armando_drake.sweep``;
- :mod:`~armando_drake.sweeps.plot`: the sweep's main figure;
- :mod:`~armando_drake.sweeps.dataset`: data sets, ``python -m armando_drake.dataset``.
"""
