"""Navigation as Nav2 computes it, without ROS: maps, costmaps and the global planner.

- :mod:`.maps`: map_server's map YAML + image into an occupancy grid (nav2_map_server's
  map_io), and map_saver's output back.
- :mod:`.costmap`: nav2_costmap_2d's static and inflation layers, with the parameters of a
  Nav2 YAML (``global_costmap``/``local_costmap``).
- :mod:`.planner`: NavFn's global plan (Dijkstra over the costmap's navigation costs).

Pure computation on numpy arrays; the Drake systems (localization, the controller) are to
come on top of it.
"""
