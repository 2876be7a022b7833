"""nav2_costmap_2d's cost values (``cost_values.hpp``): 0 free, 1..252 inflated, 253
inscribed (the robot's centre there means a collision), 254 lethal, 255 unknown."""

FREE_SPACE = 0
MAX_NON_OBSTACLE = 252
INSCRIBED_INFLATED_OBSTACLE = 253
LETHAL_OBSTACLE = 254
NO_INFORMATION = 255
