"""Errors a user causes are one sentence before any work: run folders that cannot be made, the step-signal report's
folder, an unreadable input (without a "0/N" progress line first), a road too dense for every ego."""

import os
import subprocess
import sys

import pytest
from test_cli import SMALL, invoke

RUN_COMMANDS = [["train", "--demos", "d.parquet"], ["dagger", "--demos", "d.parquet"], ["gail", "--demos", "d.parquet"],
                ["ppo"]]


@pytest.mark.parametrize("command", RUN_COMMANDS, ids=lambda command: command[0])
def test_a_run_folder_inside_a_file_is_one_sentence_before_any_work(tmp_path, command):
    (tmp_path / "file").write_text("")
    result = invoke(*command, *SMALL, "--out", str(tmp_path / "file" / "run"))
    assert result.exit_code == 2 and "Traceback" not in result.output, result.output
    assert f"run folder {tmp_path / 'file' / 'run'} cannot be made: {tmp_path / 'file'} is a file" in result.output


def test_step_signal_checks_its_report_file_before_reading_anything(tmp_path):
    result = invoke("step-signal", *SMALL, "--demos", str(tmp_path / "missing.parquet"), "--policy",
                    str(tmp_path / "missing.npz"), "--out", str(tmp_path / "no_folder" / "report.json"))
    assert result.exit_code == 2 and "the folder of output" in result.output and "does not exist" in result.output


@pytest.mark.parametrize("command", [
    ["step-signal", "--demos", "missing.parquet", "--policy", "missing.npz", "--out", "{file}/sub/report.json"],
    ["record-expert", "--episodes", "1", "--out", "{file}/demos.parquet"],
    ["evaluate", "--policy", "expert", "--episodes", "1", "--out", "{file}/metrics"],
    ["evaluate", "--policy", "expert", "--episodes", "1", "--out", "metrics", "--video", "{file}/videos"],
], ids=["step-signal", "record-expert", "evaluate", "evaluate-video"])
def test_an_output_inside_a_file_says_the_file_is_a_file(tmp_path, command, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "file").write_text("")
    result = invoke(command[0], *SMALL, *[part.format(file=tmp_path / "file") for part in command[1:]])
    assert result.exit_code == 2 and "Traceback" not in result.output, result.output
    assert f"cannot be: {tmp_path / 'file'} is a file, not a folder" in result.output, result.output
    assert "does not exist" not in result.output


def test_an_unreadable_input_is_said_without_a_progress_line_before(tmp_path):
    (tmp_path / "demos.csv").write_text("observation,action\n1,2\n")
    for command in (["train", "--iterations", "2"], ["dagger", "--rounds", "2"]):
        result = invoke(*command, *SMALL, "--demos", str(tmp_path / "demos.csv"), "--out", str(tmp_path / "run"))
        assert result.exit_code == 1 and "demos.csv" in result.output, result.output
        assert result.output.startswith("Error: ") and result.output.count("\n") == 1, result.output


def test_a_road_too_dense_for_every_ego_is_one_sentence_without_warnings_before(tmp_path):
    # traffic queues to enter the road, and (in the command and its workers) no place is safe: no ego enters
    (tmp_path / "patch").mkdir()
    (tmp_path / "patch" / "sitecustomize.py").write_text(
        "from sumo_rail.sim.placement import EgoPlacement\n"
        "EgoPlacement._safe_speed = lambda self, lane, position_m, max_speed_mps: None\n")
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(tmp_path / "patch"),
                                                                             os.environ.get("PYTHONPATH")]))}
    result = subprocess.run([sys.executable, "-m", "sumo_rail_cli", "record-expert", *SMALL, "--egos", "8", "--set",
                             "scenario.flow_veh_per_h=12000", "--episodes", "8", "--out", str(tmp_path / "d.parquet")],
                            capture_output=True, text=True, timeout=300, env=environment)
    assert result.returncode == 1, result.stderr
    assert result.stderr.splitlines() == [result.stderr.strip()], result.stderr  # one line, nothing before it
    assert result.stderr.startswith("Error: none of the 8 egos found room at 20 places of their start window ")
    assert "traffic is too dense there" in result.stderr and not (tmp_path / "d.parquet").exists()


@pytest.mark.parametrize("roads", ["", ",", " , "])
@pytest.mark.parametrize("command", ["train", "dagger"])
def test_roads_that_name_no_road_are_a_usage_error(tmp_path, command, roads):
    """An empty --roads is not the configured road by accident (run.json said roads: []): leave the option out."""
    result = invoke(command, *SMALL, "--demos", str(tmp_path / "d.parquet"), "--roads", roads, "--out",
                    str(tmp_path / "run"))
    assert result.exit_code == 2 and "--roads" in result.output and "names no road" in result.output, result.output
    assert "Traceback" not in result.output and not (tmp_path / "run").exists()
