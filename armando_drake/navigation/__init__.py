"""Navigation as Nav2 computes it, without ROS: maps, costmaps, planner, follower, AMCL.

- :mod:`.maps`: map_server's map YAML + image into an occupancy grid (nav2_map_server's
  map_io), and map_saver's output back.
- :mod:`.costmap`: nav2_costmap_2d's static and inflation layers, with the parameters of a
  Nav2 YAML (``global_costmap``/``local_costmap``).
- :mod:`.planner`: NavFn's global plan (Dijkstra over the costmap's navigation costs).
- :mod:`.world_map`: the world's true occupancy (its collision geometry cut at the
  lidar's height).
- :mod:`.follower`: the controller server's parameters, Regulated Pure Pursuit.
- :mod:`.amcl`: AMCL's particle filter (localization on the odometry and the lidar).
- :mod:`.config`, :mod:`.navigator`: the scenario's ``navigation:`` section and the Drake
  system that drives to its goals.
- :mod:`.slam`: slam_toolbox's mapping (an occupancy grid from the scans and the odometry,
  scan matching correcting the drift, map -> odom).
- :mod:`.explore`: explore_lite's frontiers, the navigator driving to them.
- :mod:`.building`: :func:`~.building.AddNavigation`, the navigation of a scenario added to a
  diagram (to goals, or exploring).

The maps, costmaps, planner and follower are pure computation on numpy arrays (SciPy
imported where used: the ``navigation`` extra).
"""
