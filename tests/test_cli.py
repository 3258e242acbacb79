from pathlib import Path

import pytest
from click.testing import CliRunner
from sumo_rail_cli.main import cli

import sumo_rail

SMALL = ["--set", "scenario.length_m=1500", "--set", "scenario.warmup_s=120", "--set", "scenario.snapshots=3",
         "--set", "scenario.snapshot_interval_s=10", "--set", "env.ego_start_max_m=500"]


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


def test_version_and_help():
    assert sumo_rail.__version__ in invoke("--version").output
    result = invoke("--help")
    assert result.exit_code == 0 and "run-episode" in result.output


def test_run_episode_prints_metrics():
    result = invoke("run-episode", *SMALL, "--driver", "random", "--seed", "2")
    assert result.exit_code == 0, result.output
    assert "average_speed_kmh" in result.output and "overtakes" in result.output
    assert "end_of_road" in result.output


@pytest.mark.parametrize(("args", "fragment"), [
    (["--set", "scenario.lanes=0"], "scenario.lanes"),
    (["--set", "scenario.colour=1"], "scenario.colour"),
    (["--set", "lanes=3"], "SECTION.KEY=VALUE"),
    (["--set", "lidar.range_m=-1"], "lidar.range_m"),
    (["--set", "lidar.beams=7"], "360"),
    (["--set", "scenario.flow_veh_per_h=-100"], "flow_veh_per_h"),
    (["--config", "does-not-exist.toml"], "does-not-exist.toml"),
    (["--episodes", "0"], "--episodes"),
])
def test_bad_input_is_a_one_line_usage_error(args, fragment):
    result = invoke("run-episode", *args)
    assert result.exit_code == 2
    assert fragment in result.output
    assert "Traceback" not in result.output
    assert isinstance(result.exception, SystemExit)


def test_unknown_key_in_config_file(tmp_path: Path):
    path = tmp_path / "bad.toml"
    path.write_text("[env]\ndecision_period = 1.0\n")
    result = invoke("run-episode", "--config", str(path))
    assert result.exit_code == 2 and "env.decision_period" in result.output
