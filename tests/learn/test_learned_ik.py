"""The learned inverse kinematics: the one command (data set, training, ONNX export,
table), the IkNetwork system, the learned_ik scenario reaching its targets, the errors.

Small data sets here (the figures of a full-size run are in docs/learned-ik.md); the
shipped network models/learned_ik/armando_ik_network.onnx is the full-size one."""

import json
import sys

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.math import RollPitchYaw
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource, ConstantVectorSource

from armando_drake import MODELS_DIR
from armando_drake.learning.network import IkModel, IkNetwork, pose_errors, refine
from armando_drake.learning.training import TrainSettings, label_branch, read_dataset
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario
from armando_drake.sweeps import learn
from armando_drake.tools.errors import ScenarioError


def assert_one_line(err: str, *needles: str) -> None:
    """``err`` is one ``error: ...`` line holding every needle, with no traceback."""
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, err
    for needle in needles:
        assert needle in lines[0], lines[0]


SHIPPED = MODELS_DIR / "learned_ik" / "armando_ik_network.onnx"
SMALL = ["--max-iter", "60", "--drake-poses", "3", "--workers", "1", "--quiet"]


@pytest.fixture(scope="module")
def armando_run(tmp_path_factory):
    """A small run of the one command on Armando: (output folder, table)."""
    folder = tmp_path_factory.mktemp("learn") / "armando"
    code = learn.main(["ik", "--samples", "3000", "--output", str(folder), *SMALL])
    assert code == 0
    return folder, json.loads((folder / "accuracy.json").read_text())


def test_one_command_makes_the_data_set_the_network_and_the_table(armando_run):
    folder, table = armando_run
    assert (folder / "ik.parquet").is_file() and (folder / "ik_network.onnx").is_file()
    markdown = (folder / "accuracy.md").read_text()
    assert "| network (ONNX Runtime) |" in markdown
    assert table["joints"] == 4 and table["frame"] == "crawer_base"
    assert table["features"][:3] == ["x", "y", "z"] and "r20" not in table["features"]
    raw, refined, drake = table["methods"]
    assert raw["poses"] == refined["poses"] == table["rows"]["held out"] > 0
    assert drake["poses"] == 3
    # Refinement improves the network's answer; Drake's IK solves the whole pose.
    assert refined["position_mm"]["p50"] < raw["position_mm"]["p50"]
    assert drake["position_mm"]["max"] < 1e-3 and drake["orientation_deg"]["max"] < 1e-3
    assert 0 < raw["ms_per_pose"] < drake["ms_per_pose"]


def test_the_exported_network_answers_in_onnx_runtime(armando_run):
    folder, _ = armando_run
    model = IkModel(folder / "ik_network.onnx")
    assert model.joint_names == ["j0", "j1", "j2", "j3"]
    assert model.metadata["robot"]["name"] == "armando"
    arm = model.make_arm()
    q = np.array([0.4, 0.6, 0.9, 0.3])
    arm.set_state(q)
    X = arm.pose()
    answer = model.predict(X)
    assert answer.shape == (4,) and np.all(np.isfinite(answer))
    assert np.all(answer >= model.lower) and np.all(answer <= model.upper)


def test_the_branch_holds_one_elbow_sign(armando_run):
    # 3000 rows are too few to keep the branch apart; 20000 are not (the full run).
    folder, _ = armando_run
    data = read_dataset(folder / "ik.parquet")
    arm = IkModel(folder / "ik_network.onnx").make_arm()
    branch = label_branch(arm, data, np.arange(len(data.q)), np.ones(4, bool), TrainSettings())
    assert 0 < len(branch.rows) < len(data.q)
    assert branch.threshold > 0


def elbow(model: IkModel, arm) -> float:
    """The sign of j2 on the network's branch of Armando's inverse kinematics."""
    arm.set_state(np.array([0.3, 0.5, 1.2, 0.2]))
    return float(np.sign(model.predict(arm.pose())[2]))


def test_the_shipped_network_is_within_5_mm_and_refines_to_round_off():
    model = IkModel(SHIPPED)
    arm = model.make_arm()
    rng = np.random.default_rng(5)
    sign = elbow(model, arm)
    raw, refined = [], []
    for _ in range(100):  # dexterous poses, the elbow as on the network's branch
        q = np.array([rng.uniform(-2, 2), rng.uniform(-1, 1), 0, rng.uniform(-1, 1)])
        q[2] = sign * rng.uniform(0.6, 2.2)
        arm.set_state(q)
        X = arm.pose()
        answer = model.predict(X)
        raw.append(pose_errors(arm, answer, X)[0])
        refined.append(pose_errors(arm, refine(arm, answer, X, 3), X)[0])
    # The run's held-out median is 4.9 mm (docs/learned-ik.md); these poses are drawn
    # otherwise (joint ranges, not the data set's), so a little slack.
    assert np.median(raw) <= 6e-3
    assert np.median(refined) <= 1e-4


@pytest.mark.parametrize("pose_input", ["vector", "rigid_transform"])
def test_ik_network_system_answers_a_pose(pose_input):
    model = IkModel(SHIPPED)
    arm = model.make_arm()
    q = np.array([0.5, 0.7, 1.1, -0.4]) * [1, 1, elbow(model, arm), 1]
    arm.set_state(q)
    X = arm.pose()
    builder = DiagramBuilder()
    network = builder.AddSystem(IkNetwork(model, refine_steps=3, pose_input=pose_input))
    if pose_input == "vector":
        vector = np.concatenate([X.translation(), RollPitchYaw(X.rotation()).vector()])
        source = builder.AddSystem(ConstantVectorSource(vector))
    else:
        source = builder.AddSystem(ConstantValueSource(AbstractValue.Make(X)))
    builder.Connect(source.get_output_port(), network.GetInputPort("pose"))
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    answer = network.GetOutputPort("positions").Eval(network.GetMyContextFromRoot(context))
    position, angle = pose_errors(arm, answer, X)
    assert position < 1e-6 and angle < 1e-5


def test_learned_ik_scenario_reaches_its_targets():
    scenario = load_scenario(
        "learned_ik",
        "logging: {console_rate: 0}\nsimulator_config: {target_realtime_rate: 0}",
    )
    scenario.learned_ik.targets = scenario.learned_ik.targets[:2]
    world = MakeWorld(scenario, quiet=True)
    simulator = Simulator(world.diagram)
    learned = world.robot().learned_ik
    assert learned.controller == "position_controller"
    for X_target, start in zip(learned.targets, learned.times, strict=True):
        simulator.AdvanceTo(start + scenario.learned_ik.period - 0.01)
        q = world.joint_positions(simulator.get_context())
        position, angle = pose_errors(learned.arm, q, X_target)
        assert position < 3e-3, (position, X_target.translation())
        assert angle < 0.03
    world.close()


def test_learn_without_the_extra_is_one_line(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "skl2onnx", None)
    with pytest.raises(SystemExit) as exited:
        learn.main(["ik", "--samples", "10", "--output", "unused"])
    assert exited.value.code == 2
    assert_one_line(capsys.readouterr().err, "skl2onnx", "pip install 'armando-drake[learn]'")


def test_a_file_that_is_no_network_is_one_line(tmp_path, capsys):
    bad = tmp_path / "net.onnx"
    bad.write_text("not a network")
    scenario = load_scenario("learned_ik", f"learned_ik: {{network: {bad}}}")
    with pytest.raises(ScenarioError) as raised:
        MakeWorld(scenario, quiet=True)
    assert "learned_ik.network" in str(raised.value) and "not an ONNX network" in str(raised.value)


def test_missing_data_set_is_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as exited:
        learn.main(["ik", "--data", str(tmp_path / "none.parquet"), "--output", str(tmp_path)])
    assert exited.value.code == 2
    assert_one_line(capsys.readouterr().err, "none.parquet", "no such file")


def test_any_arm_the_data_set_supports_the_iiwa(tmp_path):
    folder = tmp_path / "iiwa"
    code = learn.main(
        ["ik", "--robot", str(MODELS_DIR / "iiwa_description"), "--samples", "1500"]
        + ["--output", str(folder), *SMALL]
    )
    assert code == 0
    table = json.loads((folder / "accuracy.json").read_text())
    assert table["joints"] == 7
    # 1500 rows are too sparse in 7 joints to link a branch: all rows are trained on.
    assert table["rows"]["trained from"] == 1500
    raw, refined, drake = table["methods"]
    assert refined["position_mm"]["p50"] < raw["position_mm"]["p50"]
    assert len(table["features"]) == 12  # a 7-joint arm sets every rotation entry
    assert IkModel(folder / "ik_network.onnx").num_joints == 7
