"""Navigation as Nav2 computes it, without ROS: maps, costmaps, planner, follower, AMCL.

- :mod:`.maps`: map_server's map YAML + image into an occupancy grid (nav2_map_server's
  map_io), and map_saver's output back.
- :mod:`.nav2_params`: a Nav2 parameter file read once, the scenario's overrides
  (:mod:`.overrides`) applied to the parsed parameters.
- :mod:`.registry`: Nav2's plugins by name (planners, controllers, costmap layers,
  behaviours, smoothers), and the substitutions (a plugin Nav2 ships that runs as an
  implemented one).
- :mod:`.costmap`: nav2_costmap_2d's static, inflation and obstacle layers (plugins), with
  the parameters of a Nav2 YAML (``global_costmap``/``local_costmap``); :mod:`.layers`:
  the costmaps the lidar's scans update.
- :mod:`.planner`: NavFn's global plan (the planner plugin; Dijkstra over the costmap's
  navigation costs).
- :mod:`.world_map`: the world's true occupancy (its collision geometry cut at the
  lidar's height).
- :mod:`.follower`: the controller server's parameters, Regulated Pure Pursuit (the
  controller plugin), the goal and progress checkers.
- :mod:`.behaviors`: the behaviour server's recoveries (Spin, BackUp, Wait plugins);
  :mod:`.smoother`: the smoother server's slot.
- :mod:`.amcl`: AMCL's particle filter (localization on the odometry and the lidar).
- :mod:`.config`, :mod:`.navigator`, :mod:`.results`: the scenario's ``navigation:``
  section, the Drake system that drives to its goals, and their results.
- :mod:`.slam`: slam_toolbox's mapping (an occupancy grid from the scans and the odometry,
  scan matching correcting the drift, map -> odom).
- :mod:`.explore`: explore_lite's frontiers, the navigator driving to them.
- :mod:`.building`: :func:`~.building.AddNavigation`, the navigation of a scenario added to a
  diagram (to goals, or exploring), composed as Nav2 composes its servers.
- :mod:`.reference`: the parameter reference, generated from the registries and the
  parameters' declarations.

The maps, costmaps, planner and follower are pure computation on numpy arrays (SciPy
imported where used: the ``navigation`` extra).
"""
