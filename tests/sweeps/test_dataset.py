"""The inverse-kinematics data set: forward kinematics recomputed here, seeds, shards, IK."""

import numpy as np
import pyarrow.parquet as pq
import pytest
from pydrake.multibody.plant import MultibodyPlant

from armando_drake.description.loader import load_robot
from armando_drake.sweeps import dataset
from armando_drake.sweeps.dataset import IkSettings, RobotSpec, make_ik_dataset, read_metadata
from armando_drake.sweeps.engines import InProcess, LocalPool
from armando_drake.sweeps.errors import SweepError
from armando_drake.tools.version import provenance

SAMPLES = 24


def forward_kinematics(description, frame: str, joint_names, rows):
    """(positions, rotation matrices) of ``frame`` at each row's q, from a plant built here."""
    plant = MultibodyPlant(time_step=0.0)
    robot = load_robot(plant, description)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    body_frame = plant.GetFrameByName(frame, robot.model_instance)
    names = plant.GetPositionNames(
        robot.model_instance, add_model_instance_prefix=False, always_add_suffix=False
    )
    assert list(names) == joint_names
    positions, rotations = [], []
    for q in rows:
        plant.SetPositions(context, q)
        X = body_frame.CalcPoseInWorld(context)
        positions.append(X.translation())
        rotations.append(X.rotation().matrix())
    return np.array(positions), np.array(rotations)


@pytest.fixture(scope="module")
def armando_ik(tmp_path_factory):
    """24 rows of Armando with the IK solved, on a local pool of 2 workers in 3 shards."""
    path = tmp_path_factory.mktemp("ik") / "ik.parquet"
    with LocalPool(workers=2) as engine:
        make_ik_dataset(
            RobotSpec(), SAMPLES, seed=7, output=path, engine=engine, ik=IkSettings(enabled=True)
        )
    return path


def test_metadata_names_the_code_that_made_the_data_set(armando_ik):
    assert read_metadata(armando_ik)["armando_drake"] == provenance()


def test_rows_are_forward_kinematics_within_the_limits(armando_ik):
    table = pq.read_table(armando_ik).to_pydict()
    metadata = read_metadata(armando_ik)
    joints = metadata["joint_names"]
    assert joints == ["j0", "j1", "j2", "j3"]
    # The gripper's base, where the chain splits into the two fingers.
    assert metadata["frame"] == "crawer_base"
    assert (metadata["seed"], metadata["samples"]) == (7, SAMPLES)
    assert table["sample"] == list(range(SAMPLES))
    q = np.array([table[f"q_{name}"] for name in joints]).T
    assert q.shape == (SAMPLES, 4)
    lower, upper = np.array(metadata["lower"]), np.array(metadata["upper"])
    np.testing.assert_array_equal(lower, [-2.57, -3.14, -3.14, -3.14])
    assert np.all(q >= lower) and np.all(q <= upper)
    assert np.all(q.max(axis=0) - q.min(axis=0) > 2.0)  # spread over the range
    positions, rotations = forward_kinematics(None, "crawer_base", joints, q)
    got = np.array([table[c] for c in ("x", "y", "z")]).T
    np.testing.assert_allclose(got, positions, rtol=0, atol=1e-9)
    matrix = np.array([table[f"r{i}{j}"] for i in range(3) for j in range(3)]).T
    np.testing.assert_allclose(matrix.reshape(-1, 3, 3), rotations, rtol=0, atol=1e-9)
    # The quaternion is the same rotation, unit, w >= 0.
    w, x, y, z = (np.array(table[c]) for c in ("qw", "qx", "qy", "qz"))
    np.testing.assert_allclose(w**2 + x**2 + y**2 + z**2, 1.0, atol=1e-12)
    assert np.all(w >= 0)
    r00 = 1 - 2 * (y**2 + z**2)
    r01 = 2 * (x * y - z * w)
    r12 = 2 * (y * z - x * w)
    np.testing.assert_allclose(r00, matrix[:, 0], atol=1e-9)
    np.testing.assert_allclose(r01, matrix[:, 1], atol=1e-9)
    np.testing.assert_allclose(r12, matrix[:, 5], atol=1e-9)


def test_ik_solutions_reach_the_poses(armando_ik):
    table = pq.read_table(armando_ik).to_pydict()
    success = np.array(table["ik_success"])
    assert success.mean() >= 0.9, table["ik_attempts"]
    joints = ["j0", "j1", "j2", "j3"]
    solutions = np.array([table[f"ik_q_{name}"] for name in joints]).T[success]
    positions, rotations = forward_kinematics(None, "crawer_base", joints, solutions)
    target = np.array([table[c] for c in ("x", "y", "z")]).T[success]
    # Within the IK's box of 1e-6 m per axis (and the solver's own tolerance).
    assert np.abs(positions - target).max() < 1e-5
    reported = np.array(table["ik_position_error"])[success]
    np.testing.assert_allclose(reported, np.linalg.norm(positions - target, axis=1), atol=1e-12)
    assert np.array(table["ik_orientation_error"])[success].max() < 1e-3


def test_same_seed_same_rows_whatever_the_sharding(armando_ik, tmp_path):
    ik = IkSettings(enabled=True)
    again = tmp_path / "again.parquet"
    make_ik_dataset(RobotSpec(), SAMPLES, 7, again, InProcess(), ik=ik, shards=1)
    assert pq.read_table(again).equals(pq.read_table(armando_ik))
    other = tmp_path / "other.parquet"
    make_ik_dataset(RobotSpec(), 4, 8, other, InProcess())
    assert (
        pq.read_table(other)["q_j0"].to_pylist()
        != pq.read_table(armando_ik)["q_j0"].to_pylist()[:4]
    )
    assert "ik_success" not in pq.read_table(other).column_names


def test_other_robot_and_its_last_link(mini_package, tmp_path):
    # The mini robot: base_link -q1-> upper -q2-> lower -fixed-> tip.
    path = tmp_path / "mini.parquet"
    robot = RobotSpec(description=str(mini_package))
    make_ik_dataset(robot, 5, 0, path, InProcess())
    assert read_metadata(path)["frame"] == "tip"
    table = pq.read_table(path).to_pydict()
    q = np.array([table["q_q1"], table["q_q2"]]).T
    positions, _ = forward_kinematics(mini_package, "tip", ["q1", "q2"], q)
    np.testing.assert_allclose(np.array([table["x"], table["y"], table["z"]]).T, positions)
    # Straight up the tip is 0.425 m above the base: every sample is within that.
    assert np.all(np.linalg.norm(positions, axis=1) <= 0.425 + 1e-12)
    with pytest.raises(SweepError, match="'nope' is not a frame of 'mini'"):
        make_ik_dataset(RobotSpec(str(mini_package), frame="nope"), 5, 0, path, InProcess())


def test_branching_chain_needs_a_frame():
    urdf = """<robot name="two">
      <link name="b"/><link name="l"/><link name="r"/>
      <joint name="a" type="revolute"><parent link="b"/><child link="l"/></joint>
      <joint name="c" type="revolute"><parent link="b"/><child link="r"/></joint>
    </robot>"""
    with pytest.raises(SweepError, match="branch at 'b' \\(into l, r\\)"):
        dataset.end_effector_link(urdf, "b")


def test_command_writes_the_file(tmp_path, capsys):
    path = tmp_path / "cli.parquet"
    code = dataset.main(
        ["ik", "--samples", "6", "--seed", "3", "--ik", "--workers", "1", "--quiet"]
        + ["--output", str(path)]
    )
    assert code == 0
    out = capsys.readouterr().out
    assert f"6 rows, end effector 'crawer_base': {path}" in out
    assert "inverse kinematics solved for" in out
    assert pq.read_table(path).num_rows == 6
    with pytest.raises(SystemExit):
        dataset.main(["ik", "--samples", "0", "--output", str(path)])
    assert "--samples 0 must be at least 1" in capsys.readouterr().err
