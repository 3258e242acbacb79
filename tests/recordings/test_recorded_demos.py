"""`sumo-rail recorded-demos`: a scene's tracks as demonstrations in record-expert's schema, with the env's
observation computed from the scene, provenance naming the scene; train and gail take them, dagger refuses."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from recording_files import SCENE_SPEED, SCENE_SPEED_CONFIG
from sumo_rail_cli.demos_options import RECORDED_NOTE
from sumo_rail_cli.main import cli
from sumo_rail_cli.output_lock import lock_path

from sumo_rail.config import Config
from sumo_rail.datasets import file_sha256, read_metadata
from sumo_rail.recordings.road import ROAD_EDGE
from sumo_rail.recordings.scene import SceneMeta, split_table, write_scene_folder
from sumo_rail.recordings.tracks import Recording
from sumo_rail.runners.experts import RECORDED_SCENE
from sumo_rail.runners.tables import DEMONSTRATION_COLUMNS, read_demonstrations
from sumo_rail.sim.actions import Action
from sumo_rail.sim.observation import observation_names, observation_space

SMALL = ["--set", "scenario.length_m=1500", "--set", "scenario.warmup_s=120", "--set", "scenario.snapshots=3",
         "--set", "scenario.snapshot_interval_s=10", "--set", "env.ego_start_max_m=500"]
LANE_Y = (-14.4, -11.2, -8.0, -4.8, -1.6)
"""Lane centres [m] of the five 3.2 m lanes right of y = 0, rightmost first."""


def two_car_scene(folder, lanes: int = 5) -> None:
    """A truck 40 m ahead of a car in lane 1, both at 25 m/s for 4 s at 10 Hz; the car then speeds up."""
    rows = []
    for vehicle, front0, length, width, cls, accel in (("car", 100.0, 4.5, 1.8, "passenger", 2.0),
                                                       ("truck", 140.0, 12.0, 2.5, "truck", 0.0)):
        t = np.round(np.arange(0.0, 4.0 + 1e-9, 0.1), 6)
        speed = 25.0 + accel * np.maximum(t - 2.0, 0.0)
        x = front0 + 25.0 * t + 0.5 * accel * np.maximum(t - 2.0, 0.0) ** 2
        rows.append(pd.DataFrame({
            "vehicle_id": vehicle, "source_id": vehicle, "frame": np.arange(len(t)), "time_s": t, "x_m": x,
            "y_m": LANE_Y[1], "heading_deg": 90.0, "speed_mps": speed, "acceleration_mps2": 0.0, "edge": ROAD_EDGE,
            "lane": np.int16(1), "lane_position_m": x, "length_m": np.float32(length), "width_m": np.float32(width),
            "vehicle_class": cls}))
    tracks = pd.concat(rows, ignore_index=True)
    split = split_table(tracks, 0, 0.0, 0.0)
    meta = SceneMeta(format="sumo", frame_rate_hz=10.0, network="road.net.xml", lanes=lanes,
                     settings={"split_seed": 0})
    write_scene_folder(folder, Recording(tracks, 10.0, lanes, (3.2,) * lanes, 1000.0), tracks, split, meta, Config())


def invoke(*args: str):
    """sumo-rail ARGS, with the scene road's speed settings (`SCENE_SPEED`)."""
    return CliRunner().invoke(cli, [*args, *SCENE_SPEED])


def test_the_observation_is_the_envs_seen_from_the_recorded_car(tmp_path):
    two_car_scene(tmp_path / "scene")
    result = invoke("recorded-demos", str(tmp_path / "scene"), "--out", str(tmp_path / "demos.parquet"),
                    "--set", "observation.lane_block=1")
    assert result.exit_code == 0, result.output
    assert "read 16 decisions of 2 tracks (train)" in result.output  # 4 s: 8 periods each
    config = Config.from_dict({"observation": {"lane_block": 1}, **SCENE_SPEED_CONFIG})
    table = pq.read_table(tmp_path / "demos.parquet")
    assert table.column_names == list(DEMONSTRATION_COLUMNS)
    frame = table.to_pandas()
    observations = np.stack(frame["observation"].to_numpy())
    assert observations.shape == (16, observation_space(config).shape[0])
    names = observation_names(config)
    car = observations[frame["episode"].to_numpy() == 0]  # episodes in the order of the ids: car, truck
    # beam 0 looks ahead from the car's centre: the truck's rear is 40 - 12 + 4.5 / 2 m ahead, closer once the car
    # speeds up; the lane block's gap is bumper to bumper
    assert car[0, names.index("lidar_distance_00")] * config.lidar.range_m == pytest.approx(30.25, abs=1e-3)
    assert car[-1, names.index("lidar_distance_00")] * config.lidar.range_m < 30.25 - 1.0
    assert car[0, names.index("own_lane_front_gap")] * config.lidar.range_m == pytest.approx(28.0, abs=1e-3)
    assert (car[:, names.index("lane_1")] == 1).all() and (car[:, names.index("lane_0")] == 0).all()
    assert car[0, names.index("ego_speed")] == pytest.approx(25.0 / config.env.v_max_mps)
    assert car[0, names.index("lane_change_in_progress")] == 0
    # the right road edge is 1.6 + 3.2 m right of the car's lane centre
    right = names.index(f"lidar_distance_{3 * config.lidar.beams // 4:02d}")
    assert car[0, right] * config.lidar.range_m == pytest.approx(1.6 + 3.2, abs=1e-3)
    actions = frame.loc[frame["episode"] == 0, "action"].tolist()
    assert actions[:4] == [Action.KEEP] * 4 and Action.ACCELERATE in actions[4:]


def test_provenance_names_the_scene_files_vehicles_and_rule(tmp_path):
    two_car_scene(tmp_path / "scene")
    assert invoke("recorded-demos", str(tmp_path / "scene"), "--out", str(tmp_path / "d.parquet")).exit_code == 0
    record = read_metadata(tmp_path / "d.parquet")[RECORDED_SCENE]
    assert record["vehicles"] == ["car", "truck"] and record["split"] == "train"
    for name in ("tracks.parquet", "split.parquet", "scene.json", "road.net.xml"):
        path = str((tmp_path / "scene" / name).resolve())
        assert record["files"][path] == file_sha256(tmp_path / "scene" / name)
    assert record["action_rule"]["decision_period_s"] == 0.5 and record["action_rule"]["dead_band_mps2"] > 0
    assert read_demonstrations(tmp_path / "d.parquet", observation_space(Config()).shape[0]).actions.shape == (16,)


def test_a_scene_of_other_lanes_or_an_empty_split_is_a_usage_error(tmp_path):
    two_car_scene(tmp_path / "scene", lanes=3)
    result = invoke("recorded-demos", str(tmp_path / "scene"), "--out", str(tmp_path / "d.parquet"))
    assert result.exit_code == 2 and "pass --set scenario.lanes=3" in result.output
    result = invoke("recorded-demos", str(tmp_path / "scene"), "--out", str(tmp_path / "d.parquet"), "--split",
                    "test", "--set", "scenario.lanes=3")
    assert result.exit_code == 2 and "has no vehicle in the test split" in result.output
    result = invoke("recorded-demos", str(tmp_path / "nothing"), "--out", str(tmp_path / "d.parquet"))
    assert result.exit_code == 2 and "is not a readable scene folder" in result.output
    assert not (tmp_path / "d.parquet").exists()


def test_train_and_gail_take_recorded_demos_and_dagger_refuses_them(tmp_path):
    two_car_scene(tmp_path / "scene")
    demos = str(tmp_path / "demos.parquet")
    assert invoke("recorded-demos", str(tmp_path / "scene"), "--out", demos).exit_code == 0
    result = invoke("train", *SMALL, "--demos", demos, "--iterations", "1", "--set", "rail.directions=2", "--set",
                    "rail.top=1", "--set", "bc.epochs=1", "--eval-every", "1", "--eval-episodes", "1",
                    "--out", str(tmp_path / "rail"))
    assert result.exit_code == 0, result.output
    assert (tmp_path / "rail" / "policy_latest.npz").is_file()
    # what each printed number measures: BC's accuracy the recorded drivers', the validation agreement the rule's
    assert RECORDED_NOTE in result.output
    assert "iteration 1: with the rule-based normal style, not the recorded drivers: validation agreement" in \
        result.output
    result = invoke("dagger", *SMALL, "--demos", demos, "--rounds", "1", "--set", "dagger.episodes_per_round=1",
                    "--set", "bc.epochs=1", "--eval-every", "0", "--out", str(tmp_path / "dagger"))
    assert result.exit_code == 1 and "a recorded driver cannot be asked what it would do" in result.output
    assert "Traceback" not in result.output and not (tmp_path / "dagger").exists()
    pytest.importorskip("stable_baselines3", reason="gail is the package's optional extra [baselines]")
    result = invoke("gail", *SMALL, "--demos", demos, "--timesteps", "64", "--set", "gail.n_steps=32", "--set",
                    "gail.envs=1",
                    "--set", "bc.epochs=1", "--out", str(tmp_path / "gail"))
    assert result.exit_code == 0, result.output
    assert RECORDED_NOTE in result.output


def test_demonstrations_another_command_writes_are_one_sentence_and_left_alone(tmp_path):
    two_car_scene(tmp_path / "scene")
    out = tmp_path / "demos.parquet"
    holder = subprocess.Popen(["sleep", "600"])
    try:
        lock_path(out).write_text(f"{holder.pid}\n")
        result = invoke("recorded-demos", str(tmp_path / "scene"), "--out", str(out))
        assert result.exit_code == 1 and f"pid {holder.pid}" in result.output and "Traceback" not in result.output
        assert not out.exists() and lock_path(out).read_text() == f"{holder.pid}\n"
    finally:
        holder.kill()
        holder.wait()
    assert invoke("recorded-demos", str(tmp_path / "scene"), "--out", str(out)).exit_code == 0
    assert out.is_file() and not lock_path(out).exists()


LIMIT_WRONG = "scenario.speed_limit_mps=33.33 (not the road's limit)"
TOP_WRONG = "env.v_max_mps=33.33 (the highest set-point, below the limit)"


@pytest.mark.parametrize(("settings", "wrong", "fixes"), [
    ((), f"{LIMIT_WRONG} and {TOP_WRONG}",  # the defaults: 33.33 m/s
     "--set scenario.speed_limit_mps=44.44 --set env.v_max_mps=44.44"),
    (("--set", "scenario.speed_limit_mps=44.44"), TOP_WRONG, "--set env.v_max_mps=44.44"),
    (("--set", "env.v_max_mps=50"), LIMIT_WRONG, "--set scenario.speed_limit_mps=44.44"),
])
def test_a_configuration_below_the_scenes_speed_limit_is_refused(tmp_path, settings, wrong, fixes):
    """The scene's road allows 44.44 m/s: set-points clipped at the default 33.33 m/s would misread its drivers; the
    sentence names only the settings that are wrong."""
    two_car_scene(tmp_path / "scene")
    out = tmp_path / "d.parquet"
    result = CliRunner().invoke(cli, ["recorded-demos", str(tmp_path / "scene"), "--out", str(out), *settings])
    assert result.exit_code == 2 and "speed limit of 44.44 m/s" in result.output and fixes in result.output
    assert f"this configuration has {wrong}; pass" in result.output, result.output
    assert "Traceback" not in result.output and not out.exists()


def test_a_learner_below_the_speed_limit_of_the_demonstrations_scene_is_refused(tmp_path):
    two_car_scene(tmp_path / "scene")
    demos = tmp_path / "demos.parquet"
    assert invoke("recorded-demos", str(tmp_path / "scene"), "--out", str(demos)).exit_code == 0
    assert read_metadata(demos)[RECORDED_SCENE]["speed_limit_mps"] == 44.44
    for command in ("train", "gail"):
        result = CliRunner().invoke(cli, [command, *SMALL, "--demos", str(demos), "--out", str(tmp_path / command)])
        assert result.exit_code == 2 and "speed limit of 44.44 m/s" in result.output, result.output
        assert "--set scenario.speed_limit_mps=44.44 --set env.v_max_mps=44.44" in result.output
        assert not (tmp_path / command).exists()


def test_export_minari_and_step_signal_refuse_recorded_demonstrations_in_one_sentence(tmp_path):
    """Neither can use them (no seed to replay; no expert to ask): one sentence each, nothing made."""
    from sumo_rail.drivers.policies import Policy, PolicyShape, save_policy

    two_car_scene(tmp_path / "scene")
    demos = tmp_path / "demos.parquet"
    assert invoke("recorded-demos", str(tmp_path / "scene"), "--out", str(demos)).exit_code == 0
    before = sorted(tmp_path.iterdir())
    result = CliRunner().invoke(cli, ["export-minari", str(demos), "--name", "sumo-rail/recorded-v0", "--root",
                                      str(tmp_path / "minari")])
    assert result.exit_code == 1 and "read from the recorded scene" in result.output, result.output
    assert "Traceback" not in result.output and result.output.count("\n") == 1
    shape = PolicyShape("linear", observation_space(Config()).shape[0])
    policy = tmp_path.parent / f"{tmp_path.name}_policy.npz"
    save_policy(Policy(shape, np.zeros(shape.parameter_count)), policy, {})
    result = invoke("step-signal", "--demos", str(demos), "--policy", str(policy), "--out", str(tmp_path / "s.json"))
    assert result.exit_code == 1 and "a recorded driver cannot be asked" in result.output, result.output
    assert "Traceback" not in result.output and result.output.count("\n") == 1
    assert sorted(tmp_path.iterdir()) == before


@pytest.mark.parametrize(("damaged", "field"), [("tracks.parquet", None), ("scene.json", None),
                                               ("scene.json", "sources"), ("scene.json", "frame_rate_hz")])
def test_a_damaged_scene_file_is_one_sentence_naming_it_exit_1(tmp_path, damaged, field):
    """A scene file that is there but cannot be read is damaged data (exit 1), not a usage error (a missing folder,
    above, is exit 2): truncated, or scene.json with a `field` of the wrong type."""
    two_car_scene(tmp_path / "scene", lanes=3)
    path = tmp_path / "scene" / damaged
    if field is None:
        path.write_bytes(path.read_bytes()[: len(path.read_bytes()) // 2])
    else:
        path.write_text(json.dumps({**json.loads(path.read_text()), field: ["a list"]}))
    result = invoke("recorded-demos", str(tmp_path / "scene"), "--set", "scenario.lanes=3", "--out",
                    str(tmp_path / "d.parquet"))
    assert result.exit_code == 1 and damaged in result.output and "Traceback" not in result.output, result.output
    assert not (tmp_path / "d.parquet").exists()
