from pathlib import Path

import pytest

from sumo_rail.config import Config, ConfigError


def test_defaults_describe_the_paper_setting():
    config = Config()
    assert config.scenario.lanes == 5
    assert config.lidar.beams == 24 and config.lidar.beam_spacing_deg == 15.0
    assert config.env.steps_per_decision(config.scenario.step_length_s) == 5


def test_overrides_replace_only_named_keys():
    config = Config().with_overrides({"scenario": {"lanes": 3}, "env": {"v_max_mps": 30}})
    assert config.scenario.lanes == 3
    assert config.env.v_max_mps == 30.0 and isinstance(config.env.v_max_mps, float)
    assert config.lidar == Config().lidar


@pytest.mark.parametrize(("data", "fragment"), [
    ({"scenario": {"lane": 3}}, "scenario.lane"),
    ({"sensors": {}}, "sensors"),
    ({"scenario": {"lanes": 0}}, "scenario.lanes"),
    ({"scenario": {"flow_veh_per_h": -5.0}}, "scenario.flow_veh_per_h"),
    ({"lidar": {"range_m": 0.0}}, "lidar.range_m"),
    ({"lidar": {"beams": 7}}, "divide 360"),
    ({"scenario": {"lanes": "five"}}, "scenario.lanes"),
    ({"scenario": {"lanes": True}}, "scenario.lanes"),
    ({"env": {"decision_period_s": 0.25}}, "decision_period_s"),
    ({"env": {"v_min_mps": 40.0}}, "v_min"),
    ({"scenario": {"length_m": float("nan")}}, "finite"),
])
def test_bad_values_raise_one_sentence_naming_the_key(data, fragment):
    with pytest.raises(ConfigError) as error:
        Config.from_dict(data)
    message = str(error.value)
    assert fragment in message
    assert "\n" not in message


def test_toml_file_round_trip(tmp_path: Path):
    path = tmp_path / "c.toml"
    path.write_text("[scenario]\nlanes = 4\nflow_veh_per_h = 2500\n[lidar]\nrange_m = 80.0\n")
    config = Config.from_toml(path)
    assert (config.scenario.lanes, config.scenario.flow_veh_per_h, config.lidar.range_m) == (4, 2500.0, 80.0)
    assert Config.from_dict(config.to_dict()) == config


def test_unreadable_or_malformed_toml_is_a_config_error(tmp_path: Path):
    with pytest.raises(ConfigError, match="cannot read"):
        Config.from_toml(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[scenario\nlanes = ")
    with pytest.raises(ConfigError, match="not valid TOML"):
        Config.from_toml(bad)


def test_presets_are_named_changes_to_the_paper_setting():
    assert Config.preset("paper") == Config()
    assert Config.preset("recommended") == Config().with_overrides({"observation": {"lane_block": 1,
                                                                                    "route_block": 1}})
    with pytest.raises(ConfigError, match="unknown preset 'best'"):
        Config.preset("best")


def test_a_toml_file_changes_the_config_it_is_applied_to(tmp_path: Path):
    path = tmp_path / "c.toml"
    path.write_text("[scenario]\nlanes = 4\n")
    config = Config.preset("recommended").with_toml(path)
    assert (config.scenario.lanes, config.observation.lane_block) == (4, 1)


@pytest.mark.parametrize("kind", ["merge", "merge_from_ramp"])
def test_the_main_road_and_the_ramp_together_are_held_to_what_the_lanes_past_the_merge_carry(kind):
    """Five lanes past the merge carry 5 x 3000 veh/h: 14000 + 1000 is accepted, 14000 + 1500 refused, naming both
    settings; on both roads where a ramp joins (the merge_from_ramp check was never tested)."""
    accepted = Config.from_dict({"scenario": {"kind": kind, "flow_veh_per_h": 14000.0, "ramp_flow_veh_per_h": 1000.0}})
    assert accepted.scenario.ramp_flow_veh_per_h == 1000.0
    with pytest.raises(ConfigError, match=r"flow_veh_per_h plus scenario.ramp_flow_veh_per_h \(15500 veh/h\) is more "
                                          r"than the 5 lanes past the merge can carry"):
        Config.from_dict({"scenario": {"kind": kind, "flow_veh_per_h": 14000.0, "ramp_flow_veh_per_h": 1500.0}})


@pytest.mark.parametrize("lanes", [1, 3])
def test_the_road_takes_up_to_its_lanes_times_a_lanes_capacity(lanes):
    """On the straight road, exactly `lanes` x 3000 veh/h is accepted and a vehicle an hour more refused."""
    full = 3000.0 * lanes
    assert Config.from_dict({"scenario": {"lanes": lanes, "flow_veh_per_h": full}}).scenario.flow_veh_per_h == full
    with pytest.raises(ConfigError, match=rf"\({full + 1:g} veh/h\) is more than {lanes} lanes can carry"):
        Config.from_dict({"scenario": {"lanes": lanes, "flow_veh_per_h": full + 1.0}})
