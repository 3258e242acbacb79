"""Route failures reported beside collisions; failed demonstrations flagged and left out; demonstrations of another
road refused; report and --resume name what they see (issue 44, "Say what happened, everywhere")."""

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pytest
from click.testing import CliRunner
from sumo_rail_cli.main import cli
from sumo_rail_cli.running import validation_summary

from sumo_rail.config import Config
from sumo_rail.datasets import DatasetError, write_parquet
from sumo_rail.evaluation.fidelity import CONFUSION_COLUMNS
from sumo_rail.learning import validation
from sumo_rail.runners import record
from sumo_rail.runners.tables import DEMONSTRATIONS, demonstrations_table, provenance, read_demonstrations


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


def test_record_expert_reports_missed_exits_and_lane_end_stops_beside_collisions(tmp_path, monkeypatch):
    def recorded(*args: Any, **kwargs: Any) -> list[dict[str, Any]]:
        return [{"steps": 10, "collisions": 1, "missed_exits": 0, "lane_end_stops": 0},
                {"steps": 12, "collisions": 0, "missed_exits": 2, "lane_end_stops": 3}]

    monkeypatch.setattr(record, "record_demonstrations", recorded)
    result = invoke("record-expert", "--episodes", "2", "--out", str(tmp_path / "d.parquet"))
    assert result.exit_code == 0, result.output
    assert "collisions 1, missed exits 2, stops at a lane end 3" in result.output


def test_validation_measures_route_failures_and_its_line_says_them(monkeypatch):
    episodes = pd.DataFrame({**{name: [1, 1] for name in CONFUSION_COLUMNS}, "average_speed_kmh": [90.0, 100.0],
                             "overtakes": [1, 0], "lane_changes": [2, 0], "longitudinal_reward": [1.0, 1.0],
                             "lateral_reward": [0.0, 0.0], "collisions": [0, 0], "merges": [0, 0],
                             "missed_exits": [1, 0], "lane_end_stops": [0, 3]})
    monkeypatch.setattr(validation, "evaluate", lambda *args, **kwargs: SimpleNamespace(metrics=episodes))
    row = validation.validate(None, Config(), None, validation.Validation(1, 2), None)
    assert row["eval_missed_exits"] == 0.5 and row["eval_lane_end_stops"] == 1.5
    assert {"eval_missed_exits", "eval_lane_end_stops"} <= set(validation.validation_columns())
    line = validation_summary(row, 2)
    assert "collisions 0.00, missed exits 0.50, stops at a lane end 1.50" in line
    old = {name: value for name, value in row.items() if name not in ("eval_missed_exits", "eval_lane_end_stops")}
    assert validation_summary(old, 2).endswith("collisions 0.00")  # a log written before them


def demos_file(path: Path, config: Config, terminations: list[str] | None) -> Path:
    """Three episodes of two decisions each; their `termination` (no such column: a file written before it)."""
    from sumo_rail.sim.observation import observation_space

    size = observation_space(config).shape[0]
    episodes = np.repeat(np.arange(3), 2)
    columns = {"episode": pa.array(episodes, pa.int32()), "action": pa.array(episodes % 5, pa.int8()),
               "observation": pa.FixedSizeListArray.from_arrays(pa.array(np.ones(6 * size, np.float32)), size)}
    if terminations is not None:
        columns["termination"] = pa.array(np.repeat(terminations, 2), pa.string())
    write_parquet(pa.table(columns), path, provenance(DEMONSTRATIONS, config, 0))
    return path


def test_failed_demonstration_episodes_are_flagged_and_left_out_unless_asked_for(tmp_path):
    config = Config()
    path = demos_file(tmp_path / "d.parquet", config, ["time_limit", "lane_end", "missed_exit"])
    assert set(read_demonstrations(path, include_failed=False).episodes) == {0}
    assert set(read_demonstrations(path).episodes) == {0, 1, 2}
    old = demos_file(tmp_path / "old.parquet", config, None)
    assert set(read_demonstrations(old, include_failed=False).episodes) == {0, 1, 2}
    collided = demos_file(tmp_path / "c.parquet", config, ["collision"] * 3)
    with pytest.raises(DatasetError, match="--include-failed-demos"):
        read_demonstrations(collided, include_failed=False)
    result = SimpleNamespace(steps={"action": np.zeros(2)}, metrics={"termination": "lane_end", "terminated": True,
                                                                      "truncated": False})
    result.steps |= {name: np.zeros(2) for name in ("reward", "reward_longitudinal", "reward_lateral",
                                                     "reward_collision", "speed_mps", "lane", "position_m",
                                                     "set_point_mps", "lane_change_in_progress")}
    result.steps["observation"] = np.zeros((2, 4))
    assert demonstrations_table([result], [7], 4).column("termination").to_pylist() == ["lane_end"] * 2


def test_train_says_how_many_failed_episodes_it_left_out(tmp_path, monkeypatch):
    from sumo_rail.learning.rail import trainer

    given = []
    monkeypatch.setattr(trainer, "train", lambda out, settings, *args, **kwargs: given.append(settings)
                        or SimpleNamespace(iteration=0))
    path = demos_file(tmp_path / "d.parquet", Config(), ["time_limit", "collision", "lane_end"])
    result = invoke("train", "--demos", str(path), "--out", str(tmp_path / "run"))
    assert result.exit_code == 0, result.output
    assert "left out 2 failed demonstration episodes" in result.output and not given[0].include_failed_demos
    result = invoke("train", "--demos", str(path), "--include-failed-demos", "--out", str(tmp_path / "run2"))
    assert "left out" not in result.output and given[1].include_failed_demos


@pytest.mark.parametrize("command", ["train", "dagger", "gail"])
def test_demonstrations_of_another_road_are_refused_unless_asked_for(tmp_path, command):
    recommended = Config.preset("recommended")
    path = demos_file(tmp_path / "d.parquet", recommended.with_overrides({"scenario": {"kind": "exit"}}), None)
    result = invoke(command, "--demos", str(path), "--out", str(tmp_path / "run"))
    assert result.exit_code == 2
    assert f"recorded on the exit road, this run drives on {recommended.scenario.kind}" in result.output
    assert "--demos-from-other-road" in result.output and "Traceback" not in result.output


def test_a_size_mismatch_from_another_lane_count_names_the_lane_count(tmp_path):
    four_lanes = Config.preset("recommended").with_overrides({"scenario": {"lanes": 4}})
    path = demos_file(tmp_path / "d.parquet", four_lanes, None)
    result = invoke("train", "--demos", str(path), "--out", str(tmp_path / "run"))
    assert result.exit_code == 2 and "recorded on a road of 4 lanes, this run's has 5" in result.output
    assert "preset" not in result.output
    with pytest.raises(DatasetError, match="lane count") as error:
        read_demonstrations(path, observation_size=56)
    assert "preset" not in str(error.value)


def test_demonstrations_of_another_road_train_with_the_option(tmp_path, monkeypatch):
    from sumo_rail.learning.rail import trainer

    monkeypatch.setattr(trainer, "train", lambda *args, **kwargs: SimpleNamespace(iteration=0))
    recommended = Config.preset("recommended")
    path = demos_file(tmp_path / "d.parquet", recommended.with_overrides({"scenario": {"kind": "exit"}}), None)
    result = invoke("train", "--demos", str(path), "--demos-from-other-road", "--out", str(tmp_path / "run"))
    assert result.exit_code == 0, result.output


def test_resume_on_another_commands_folder_names_that_command_and_resume_is_advised_only_where_it_works(tmp_path):
    from sumo_rail.learning.run_folder import RunError, check_resumable, start_run_folder

    record = {"settings": {}, "config": {}, "kind": "gail_run"}
    folder = tmp_path / "run"
    start_run_folder(folder, record)
    (folder / "checkpoint.pt").write_bytes(b"x")
    with pytest.raises(RunError, match="was made by gail, not by dagger: resume it with that command"):
        check_resumable(folder, "checkpoint.json", {**record, "kind": "dagger_run"})
    with pytest.raises(RunError, match="holds a run made by gail, not by train; choose another --out"):
        start_run_folder(folder, {**record, "kind": "training_run"})
    with pytest.raises(RunError, match="pass --resume to continue it"):
        start_run_folder(folder, record)
    (folder / "checkpoint.pt").unlink()  # stopped before its first update: nothing to resume
    with pytest.raises(RunError, match="holds no run to continue; choose another --out") as error:
        start_run_folder(folder, record)
    assert "--resume" not in str(error.value)
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    with pytest.raises(RunError, match="holds no run to continue"):
        start_run_folder(other, record)


def test_a_run_started_before_include_failed_demos_resumes_as_a_run_without_it(tmp_path):
    from sumo_rail.learning.run_folder import RunError, check_resumable, start_run_folder

    folder = tmp_path / "run"
    start_run_folder(folder, {"settings": {"kind": "mlp"}, "config": {}, "kind": "dagger_run"})
    (folder / "checkpoint.json").write_text("{}")
    record = {"settings": {"kind": "mlp", "include_failed_demos": False}, "config": {}, "kind": "dagger_run"}
    check_resumable(folder, "checkpoint.json", record)
    with pytest.raises(RunError, match="other settings"):
        check_resumable(folder, "checkpoint.json",
                        {**record, "settings": {"kind": "mlp", "include_failed_demos": True}})
