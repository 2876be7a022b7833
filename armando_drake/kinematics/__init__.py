"""Task-space motion and torque control.

- :mod:`~armando_drake.kinematics.time_laws`: s(t) with s', s'' (trapezoidal, cubic, quintic);
- :mod:`~armando_drake.kinematics.paths`: linear and circular paths, held or slerped
  orientation, their composition with a time law (the Cartesian reference);
- :mod:`~armando_drake.kinematics.arm`: the arm's kinematics and dynamics from the plant,
  damped / weighted pseudo-inverses, prioritised tasks with a null-space term;
- :mod:`~armando_drake.kinematics.inverse_kinematics`: Drake's InverseKinematics for single
  poses, the joint reference along a path by closed-loop inverse kinematics;
- :mod:`~armando_drake.kinematics.control_laws`: joint-space and operational-space inverse
  dynamics with their parameter dataclasses;
- :mod:`~armando_drake.kinematics.controller`: the law as a discrete-update Drake system of
  its own (for bare diagrams; the world runs the laws as the registered controller
  types of :mod:`armando_drake.control.controllers.task_space`, in the controller
  manager);
- :mod:`~armando_drake.kinematics.motion`: a motion as a scenario file gives it (YAML).
"""
