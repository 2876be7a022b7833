"""The scenario's task: a task-space motion of the end effector published to the
controller that takes it (the math is :mod:`armando_drake.kinematics`)."""
