"""Perception: point clouds from the cameras' depth images and a pipeline of steps on them.

- :mod:`~armando_drake.perception.config`: the scenario's ``perception:`` block, its steps;
- :mod:`~armando_drake.perception.pipeline`: the steps run on a Drake ``PointCloud``;
- :mod:`~armando_drake.perception.systems`: the Drake systems (camera pose, the pipeline
  at its rate, Meshcat layers, ``clusters.json``) and :func:`AddPerception`.
"""
