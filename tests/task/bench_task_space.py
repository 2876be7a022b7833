"""Speed of the task-space torque controllers on the iiwa at 1 kHz (a script, not a test).

    PYTHONPATH=$PWD:tests:tests/task python tests/task/bench_task_space.py

Prints, for each law, the controller's cost per tick (one ``CalcActuation``, the
work of one discrete update, median over many ticks) and the real-time factor of a
5 s closed-loop run (circle of radius 0.1 m in 4.5 s, trapezoidal law, 0.5 s
settling; plant and controller at 1 ms; the reference planned beforehand).
"""

import time

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from task_robots import IIWA_END_EFFECTOR, add_iiwa

from armando_drake.kinematics.arm import ArmModel
from armando_drake.kinematics.control_laws import (
    JointSpaceInverseDynamics,
    OperationalSpaceInverseDynamics,
)
from armando_drake.kinematics.controller import AddTorqueController
from armando_drake.kinematics.inverse_kinematics import plan_joint_reference, solve_ik
from armando_drake.kinematics.paths import CartesianTrajectory, CircularPath, OrientationPath
from armando_drake.kinematics.time_laws import TrapezoidalTimeLaw

PERIOD = 1e-3  # [s]
X_START = RigidTransform(RotationMatrix.MakeYRotation(np.pi), [0.55, 0.0, 0.5])
SEED = np.array([0.0, 0.6, 0.0, -1.4, 0.0, 0.9, 0.0])


def main() -> None:
    for name in ("joint_space", "operational_space"):
        builder = DiagramBuilder()
        plant = builder.AddNamedSystem("plant", MultibodyPlant(PERIOD))
        add_iiwa(plant)
        plant.Finalize()
        arm = ArmModel(plant=plant, end_effector_frame=IIWA_END_EFFECTOR)
        q0 = solve_ik(arm, X_START, q_seed=SEED).q
        trajectory = CartesianTrajectory(
            time_law=TrapezoidalTimeLaw(duration=4.5, acceleration_time=1.0),
            path=CircularPath(start=X_START.translation(), radius=0.1),
            orientation=OrientationPath(start=X_START.rotation()),
        )
        started = time.perf_counter()
        if name == "joint_space":
            plan = plan_joint_reference(arm, trajectory, q0, period=PERIOD, settle_time=0.5)
            law, reference = JointSpaceInverseDynamics(arm=arm), plan.as_reference_trajectory()
        else:
            law = OperationalSpaceInverseDynamics(arm=arm)
            reference = trajectory.as_reference_trajectory(PERIOD)
        preparation = time.perf_counter() - started
        # Cost per tick: the law on the reference samples of the run.
        samples = [reference.value(k * PERIOD)[:, 0] for k in range(0, 5000, 10)]
        state = np.concatenate([q0, np.zeros(7)])
        costs = []
        for sample in samples:
            tick = time.perf_counter()
            law.CalcActuation(state, sample)
            costs.append(time.perf_counter() - tick)
        AddTorqueController(builder, plant=plant, law=law, reference=reference, period=PERIOD)
        simulator = Simulator(builder.Build())
        context = simulator.get_mutable_context()
        plant.SetPositions(plant.GetMyMutableContextFromRoot(context), q0)
        simulator.Initialize()
        started = time.perf_counter()
        simulator.AdvanceTo(5.0)
        wall = time.perf_counter() - started
        print(
            f"{name:18s} per tick {np.median(costs) * 1e6:6.1f} us (median, "
            f"p90 {np.percentile(costs, 90) * 1e6:6.1f} us); 5 s closed loop in {wall:.2f} s "
            f"wall: real-time factor {5.0 / wall:.2f}; reference prepared in {preparation:.2f} s"
        )


if __name__ == "__main__":
    main()
