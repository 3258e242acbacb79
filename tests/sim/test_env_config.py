"""gymnasium.make(ENV_ID, config=...) takes a nested dict, a Config or a TOML path, as highway-env users expect."""

import gymnasium
import pytest

import sumo_rail
from sumo_rail.config import Config, ConfigError
from sumo_rail.sim.observation import observation_names

SMALL = {"scenario": {"lanes": 3, "length_m": 1500.0, "warmup_s": 60.0, "snapshots": 2},
         "env": {"ego_start_min_m": 300.0, "ego_start_max_m": 500.0}}


def test_make_with_a_nested_dict_configures_and_runs_the_env():
    env = gymnasium.make(sumo_rail.ENV_ID, config=SMALL)
    try:
        config = env.unwrapped.config
        assert config.scenario.lanes == 3 and config.scenario.length_m == 1500.0
        observation, info = env.reset(seed=0)
        assert len(observation) == len(observation_names(config)) and 0 <= info["lane"] < 3
    finally:
        env.close()


def test_make_with_a_toml_path_or_a_config(tmp_path):
    path = tmp_path / "highway.toml"
    path.write_text("[scenario]\nlanes = 4\n[lidar]\nrange_m = 80.0\n")
    for value in (path, str(path)):
        env = gymnasium.make(sumo_rail.ENV_ID, config=value)
        assert env.unwrapped.config.scenario.lanes == 4 and env.unwrapped.config.lidar.range_m == 80.0
        env.close()
    config = Config.from_dict(SMALL)
    env = gymnasium.make(sumo_rail.ENV_ID, config=config)
    assert env.unwrapped.config is config
    env.close()


@pytest.mark.parametrize(("value", "fragment"), [
    ({"scenario": {"lanes": 0}}, "scenario.lanes must be between 1 and 10"),
    ({"scenario": {"lane": 3}}, "unknown config key(s) ['scenario.lane']"),
    ({"sensor": {}}, "unknown config section(s) ['sensor']"),
    ("/nonexistent/highway.toml", "cannot read config file /nonexistent/highway.toml"),
    (42, "config must be a Config, a nested dict of sections or the path of a TOML file, got int"),
])
def test_bad_config_is_the_cli_s_one_sentence_error(value, fragment):
    with pytest.raises(ConfigError) as caught:
        gymnasium.make(sumo_rail.ENV_ID, config=value)
    message = str(caught.value)
    assert fragment in message and "\n" not in message
