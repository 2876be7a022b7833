"""Steering the running world by hand, as the course does with joint_state_publisher's
sliders, rqt's controller GUIs and a joystick: Meshcat's joint sliders, Cartesian jog
buttons and keys (through differential inverse kinematics) and a gamepad, all
publishing on the command topic of a position controller.

- ``config.py``: the scenario's ``jog:`` block (:class:`~.config.JogConfig`);
- ``gamepad.py``: the gamepad mapping, a pure function of one gamepad state;
- ``jog.py``: the jog system (:class:`~.jog.MeshcatJog`) and ``AddJog``.
"""
