"""navigation.params_overrides: Nav2 parameters replaced by dotted path, typed as the file's."""

from pathlib import Path

import pytest
import yaml

from armando_drake.navigation.follower import controller_parameters
from armando_drake.navigation.nav2_params import read_nav2
from armando_drake.navigation.overrides import apply_overrides
from armando_drake.tools.errors import ConfigError

NAV2 = Path(__file__).parents[2] / "models/fra2mo_description/config/navigation.yaml"


def test_overrides_reach_the_readers_with_the_files_types():
    overrides = {
        "controller_server.FollowPath.desired_linear_vel": 0.25,
        "controller_server.FollowPath.use_collision_detection": 0,
        "amcl.max_particles": 200.0,
    }
    before = NAV2.read_text()
    merged = read_nav2(NAV2, overrides)
    assert merged.path == NAV2  # the parsed file, overridden: no other file
    doc = merged.doc
    amcl = doc["amcl"]["ros__parameters"]
    assert amcl["max_particles"] == 200 and type(amcl["max_particles"]) is int
    follow = doc["controller_server"]["ros__parameters"]["FollowPath"]
    assert follow["use_collision_detection"] is False
    assert controller_parameters(merged).rpp.desired_linear_vel == 0.25
    assert controller_parameters(NAV2).rpp.desired_linear_vel == 0.4  # the file is untouched
    assert NAV2.read_text() == before
    assert read_nav2(NAV2, {}).doc == yaml.safe_load(before)


def test_a_wrong_path_or_type_is_refused_by_name():
    doc = yaml.safe_load(NAV2.read_text())
    with pytest.raises(ConfigError, match=r"controller_server.FolowPath.*no 'controller_server"):
        apply_overrides(doc, {"controller_server.FolowPath.lookahead_dist": 0.5})
    with pytest.raises(ConfigError, match=r"FolowPath.*in .*navigation.yaml \(there:"):
        read_nav2(NAV2, {"controller_server.FolowPath.lookahead_dist": 0.5})
    with pytest.raises(ConfigError, match=r"amcl.max_particles=2.5: an integer is needed"):
        apply_overrides(doc, {"amcl.max_particles": 2.5})
    with pytest.raises(ConfigError, match=r"use_interpolation=2.0: .*true/false"):
        apply_overrides(doc, {"controller_server.FollowPath.use_interpolation": 2.0})


@pytest.mark.parametrize(
    "navigation, expected",
    [
        ({"reached": 3, "goals": [{}] * 4}, "navigating to goals, 3/4 reached"),
        (
            {"reached": 0, "goals": [{}] * 4, "mapping": {"done": True, "frontiers_left": 0}},
            "exploring, done, 0 frontiers left",
        ),
    ],
)
def test_the_run_headline_says_what_the_navigation_did(navigation, expected):
    from armando_drake.simulation.run import RunResult

    result = RunResult(
        scenario="s.yaml", controller="navigation", sim_time=1.0, wall_time=1.0,
        realtime_factor=1.0, interrupted=False, joint_names=[], navigation=navigation,
    )  # fmt: skip
    assert expected in result.headline()
