"""Drivers in held-out recorded drivers' seats: which seats, the measures against the human's track, the tables,
`sumo-rail evaluate-scene` end to end and its refusals."""

from __future__ import annotations

import json
import shutil
import signal
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from recording_files import SCENE_SPEED
from reliability import stopped_after
from sumo_rail_cli.main import cli

from sumo_rail.config import Config
from sumo_rail.datasets import file_sha256, read_metadata
from sumo_rail.drivers.policies import Policy, PolicyShape, save_policy
from sumo_rail.evaluation.human_likeness import position_errors
from sumo_rail.evaluation.scene_evaluation import (
    HUMAN,
    evaluate_seats,
    human_track,
    seat_columns,
    tracks_path,
)
from sumo_rail.evaluation.scene_summary import distribution_samples, track_table
from sumo_rail.recordings.scene import read_scene
from sumo_rail.recordings.scene_observations import SceneFrames, scene_road
from sumo_rail.recordings.seats import choose_seats
from sumo_rail.runners.backends import SerialBackend
from sumo_rail.runners.factory import make_backend
from sumo_rail.runners.rollout import KeepDriver, SumoIdmDriver
from sumo_rail.sim.actions import action_count
from sumo_rail.sim.observation import observation_names

CONFIG = Config.from_dict({"observation": {"lane_block": 1}, "env": {"max_episode_s": 10.0}})


def test_seats_are_held_out_cars_whose_tracks_cover_the_episode(drivers_scene):
    scene = read_scene(drivers_scene)
    seats = choose_seats(scene, "test", horizon_s=10.0, lead_s=2.0, limit=None, seed=0)
    test = set(scene.split.loc[scene.split["split"] == "test", "vehicle_id"])
    spans = scene.tracks.groupby("vehicle_id").agg(begin=("time_s", "min"), end=("time_s", "max"),
                                                   kind=("vehicle_class", "first"))
    fitting = spans[(spans["end"] - spans["begin"] >= 12.0) & (spans["kind"] == "passenger")].index
    assert {seat.vehicle for seat in seats} == test & set(fitting) and len(seats) >= 3
    assert all(seat.start_s == pytest.approx(spans.at[seat.vehicle, "begin"] + 2.0) for seat in seats)
    drawn = choose_seats(scene, "test", 10.0, 2.0, limit=2, seed=5)
    assert drawn == choose_seats(scene, "test", 10.0, 2.0, limit=2, seed=5) and len(drawn) == 2
    assert {seat.vehicle for seat in drawn} <= {seat.vehicle for seat in seats}


def test_no_seat_starts_before_sumos_first_step_and_every_seat_still_covers_its_horizon(drivers_scene):
    """With --lead-s 0 a car on the road at the scene's first instant would be seated at 0 s, before SUMO's run can
    begin (one step): it is taken one step in, and left out when its track then no longer covers the horizon."""
    scene = read_scene(drivers_scene)
    first = scene.tracks["time_s"].min()
    assert first < 0.1 and (scene.tracks.groupby("vehicle_id")["time_s"].min() == first).any()
    seats = choose_seats(scene, "test", 10.0, 0.0, None, 0, earliest_s=0.1)
    ends = scene.tracks.groupby("vehicle_id")["time_s"].max()
    assert seats and all(seat.start_s >= 0.1 - 1e-9 for seat in seats)
    assert all(ends[seat.vehicle] >= seat.start_s + 10.0 - 1e-9 for seat in seats)
    assert any(seat.start_s < 0.1 for seat in choose_seats(scene, "test", 10.0, 0.0, None, 0))


def test_the_humans_track_is_its_recorded_one_with_the_gap_to_its_leader(drivers_scene):
    scene = read_scene(drivers_scene)
    seat = choose_seats(scene, "test", 10.0, 2.0, None, 0)[0]
    road = scene_road(scene.network)
    human = human_track(SceneFrames(scene.tracks, scene.meta.frame_rate_hz), seat, 0.5, 20, road, road.route, 100.0)
    recorded = scene.track(seat.vehicle)
    ahead = recorded[recorded["time_s"] >= seat.start_s]
    assert len(human) == 21 and np.allclose(position_errors(human, ahead, (1.0, 5.0, 10.0)), 0)
    at = scene.tracks[np.isclose(scene.tracks["time_s"], seat.start_s)]
    me = at[at["vehicle_id"] == seat.vehicle].iloc[0]
    ahead = at[(at["lane"] == me["lane"]) & (at["lane_position_m"] - at["length_m"] > me["lane_position_m"])]
    gap = (ahead["lane_position_m"] - ahead["length_m"]).min() - me["lane_position_m"]
    assert human["gap_m"].iloc[0] == pytest.approx(gap) if gap <= 100 else np.isnan(human["gap_m"].iloc[0])


def test_progress_and_lane_changes_are_measured_against_the_human():
    times = np.arange(0.0, 10.5, 0.5)
    human = pd.DataFrame({"time_s": times, "x_m": 30.0 * times, "y_m": 0.0, "speed_mps": 30.0, "lane": 0,
                          "lane_position_m": 30.0 * times, "gap_m": np.nan})
    driven = human.assign(x_m=20.0 * times, lane_position_m=20.0 * times, lane=np.where(times >= 5, 1, 0))
    columns = seat_columns(driven, human, simulated_s=10.0)
    assert columns["progress_ratio"] == pytest.approx(2 / 3)
    assert columns["lane_changes_per_km"] == pytest.approx(1 / 0.2)
    assert columns["position_error_1s_m"] == pytest.approx(10.0) and columns["position_error_10s_m"] == 100.0
    assert not columns["stopped"]
    early = seat_columns(driven[times <= 4.0].assign(speed_mps=0.2), human, simulated_s=4.0)  # it stopped at 4 s
    assert early["progress_ratio"] == pytest.approx(80.0 / 120.0) and early["stopped"]
    assert np.isnan(early["position_error_5s_m"]) and early["lane_changes_per_km"] == 0.0


def test_lane_change_gaps_are_the_gaps_in_the_new_lane():
    track = pd.DataFrame({"speed_mps": [30.0, 31.0, 31.0, 29.0], "lane": [0, 0, 1, 1],
                          "gap_m": [50.0, 40.0, 12.0, 15.0]})
    samples = distribution_samples(track, 0.5)
    assert samples["lane_change_gap"].tolist() == [12.0]
    assert samples["acceleration"].tolist() == [2.0, 0.0, -4.0]


def test_a_difference_row_is_paired_seat_by_seat_and_starred_when_detectable():
    rng = np.random.default_rng(0)
    base = pd.DataFrame({"mode": "reactive", "scene": "s", "vehicle": [f"v{k}" for k in range(30)],
                         "start_s": 1.0, "collisions": 0, "at_fault_collisions": 0, "stopped": False,
                         "progress_ratio": 1.0, "lane_changes": 0, "distance_m": 400.0, "hard_braking": 0,
                         "ttc_below_1_5s_share": 0.0, "steps": 30, "driving_score": 1.0,
                         "position_error_1s_m": 1.0, "position_error_5s_m": 5.0,
                         "position_error_10s_m": rng.uniform(10, 20, 30)})
    worse = base.assign(policy="rail", position_error_10s_m=base["position_error_10s_m"] + 3.0)
    shuffled = pd.concat([base.assign(policy="bc"), worse]).sample(frac=1.0, random_state=1)  # rows in any order
    table = track_table(shuffled, {"BC": ["bc"], "RAIL": ["rail"]}, [("RAIL", "BC")])
    row = next(line for line in table.splitlines() if line.startswith("| RAIL - BC"))
    assert "+3.00 [+3.00, +3.00] *" in row  # the seat-to-seat spread cancels out of the paired difference


def test_a_share_pooled_over_training_runs_has_no_interval_below_0():
    """Three training runs in 100 seats, one of them at fault in 3: the "at fault" and "collisions" cells (shares)
    keep their intervals within [0, 1] where Student's t about 0.01 would reach below 0 (issue 51)."""
    seats = pd.DataFrame({"mode": "reactive", "scene": "s", "vehicle": [f"v{k}" for k in range(100)],
                          "start_s": 1.0, "stopped": False, "progress_ratio": 1.0, "lane_changes": 0,
                          "distance_m": 400.0, "hard_braking": 0, "ttc_below_1_5s_share": 0.0, "steps": 30,
                          "driving_score": 1.0, "position_error_1s_m": 1.0, "position_error_5s_m": 5.0,
                          "position_error_10s_m": 10.0})
    runs = [seats.assign(policy=f"bc_s{seed}", collisions=hits, at_fault_collisions=hits)
            for seed, hits in enumerate(([1] * 3 + [0] * 97, 0, 0))]
    table = track_table(pd.concat(runs), {"BC": [f"bc_s{seed}" for seed in range(3)]})
    header, _, row = table.splitlines()
    cells = dict(zip(header.strip("|").split(" | "), row.strip("|").split(" | "), strict=True))
    for measure in ("collisions", "at fault"):
        estimate, low, high = _numbers(cells[measure])
        assert estimate == pytest.approx(0.01) and low == 0.0 < high <= 1.0, cells[measure]


def _numbers(cell: str) -> tuple[float, float, float]:
    """(estimate, low, high) of a cell "0.01 [0.00, 0.03]"."""
    estimate, bounds = cell.strip().split(" [")
    low, high = bounds.rstrip("]").split(", ")
    return float(estimate), float(low), float(high)


def test_the_same_seed_gives_the_same_episodes_whatever_the_workers(drivers_scene):
    scene = read_scene(drivers_scene)
    seats = choose_seats(scene, "test", 10.0, 2.0, 3, 0)
    runs = []
    for backend in (SerialBackend(), make_backend("process", 2)):
        with backend:
            runs.append(evaluate_seats([KeepDriver(), SumoIdmDriver()], ["keep", "sumo-idm"], CONFIG, seats,
                                       ["non-reactive", "reactive"], backend, seed=7))
    pd.testing.assert_frame_equal(runs[0].metrics, runs[1].metrics)
    pd.testing.assert_frame_equal(runs[0].decisions, runs[1].decisions)
    metrics, tracks = runs[0].metrics, runs[0].decisions
    assert len(metrics) == 2 * 3 * 2 and set(tracks["policy"]) == {"keep", "sumo-idm", HUMAN}
    with SerialBackend() as backend:  # the same driver twice keeps both names (evaluate-scene's "keep#2")
        twice = evaluate_seats([KeepDriver(), KeepDriver()], ["keep", "keep#2"], CONFIG, seats[:1],
                               ["reactive"], backend, seed=7).metrics
    assert twice["policy"].tolist() == ["keep", "keep#2"]


@dataclass(frozen=True)
class _AsksForSumo:
    """A driver of its own (no class the evaluation knows) that asks the seat for SUMO's controller."""

    name: str = "own-idm"
    controller: str = "sumo"

    def create(self, config, seed):
        return KeepDriver().create(config, seed)


def test_any_driver_asking_for_sumos_controller_is_driven_by_sumo_in_the_seat(drivers_scene):
    """sumo-idm is a controller like any other: a driver spec naming "sumo" drives as sumo-idm does, not as keep."""
    seats = choose_seats(read_scene(drivers_scene), "test", 10.0, 2.0, 2, 0)
    with SerialBackend() as backend:
        metrics = evaluate_seats([SumoIdmDriver(), _AsksForSumo(), KeepDriver()], ["sumo-idm", "own-idm", "keep"],
                                 CONFIG, seats, ["reactive"], backend, seed=7).metrics
    driving = ["distance_m", "lane_changes", "position_error_10s_m"]
    by_driver = {name: rows[driving].reset_index(drop=True) for name, rows in metrics.groupby("policy")}
    pd.testing.assert_frame_equal(by_driver["own-idm"], by_driver["sumo-idm"])
    assert not by_driver["own-idm"].equals(by_driver["keep"])


def test_the_gap_to_the_leader_is_measured_within_the_lidars_range(drivers_scene):
    """The driven and the human tracks' gaps are one measure, within lidar.range_m (not a fixed 100 m)."""
    seats = choose_seats(read_scene(drivers_scene), "test", 10.0, 2.0, None, 0)
    tracks = {}
    with SerialBackend() as backend:
        for range_m in (100.0, 40.0):  # the ego sees 20 m farther (CONTEXT_MARGIN_M): gaps of 40 to 60 m too
            config = CONFIG.with_overrides({"lidar": {"range_m": range_m}})
            tracks[range_m] = evaluate_seats([KeepDriver()], ["keep"], config, seats, ["non-reactive"], backend,
                                             seed=0).decisions
    for driver in ("keep", HUMAN):
        wide, narrow = (tracks[range_m][tracks[range_m]["policy"] == driver]["gap_m"] for range_m in (100.0, 40.0))
        assert wide.between(40.0, 60.0, inclusive="neither").any() and narrow.notna().any(), driver
        assert not (narrow > 40.0).any(), driver


def invoke(*args: str):
    """sumo-rail evaluate-scene ARGS, with the scene road's speed settings (`SCENE_SPEED`)."""
    return CliRunner().invoke(cli, ["evaluate-scene", *args, *SCENE_SPEED])


def test_evaluate_scene_writes_both_tables_with_provenance(drivers_scene, tmp_path):
    out = tmp_path / "scene_eval.parquet"
    result = invoke(str(drivers_scene), "--set", "observation.lane_block=1", "--set", "scenario.lanes=3",
                    "--policy", "keep", "--policy", "sumo-idm", "--seats", "2", "--horizon-s", "10", "--lead-s", "2",
                    "--mode", "reactive",
                    "--out", str(out))
    assert result.exit_code == 0, result.output
    assert "position error 10 s [m]" in result.output and "lane-change gap [m]" in result.output
    metrics, tracks = pd.read_parquet(out), pd.read_parquet(tracks_path(out))
    assert len(metrics) == 4 and set(metrics["mode"]) == {"reactive"}
    assert (tracks["policy"] == HUMAN).sum() == 2 * 21
    metadata = read_metadata(out)
    assert metadata["kind"] == "scene_episodes" and metadata["split"] == "test"
    assert (metadata["seat_classes"], metadata["seats"], metadata["lead_s"]) == (["passenger"], 2, 2.0)
    sources = metadata["scenes"][str(drivers_scene.resolve())]  # each scene file with its sha256
    assert sources[str((drivers_scene / "tracks.parquet").resolve())] == file_sha256(drivers_scene / "tracks.parquet")


@pytest.mark.parametrize("damaged", ["tracks.parquet", "split.parquet", "scene.json"])
def test_a_damaged_scene_file_is_one_sentence_naming_it_exit_1(drivers_scene, tmp_path, damaged):
    """A scene file that is there but cannot be read is damaged data (exit 1, as recorded-demos says it), not a usage
    error (a missing scene folder is exit 2, below)."""
    scene = tmp_path / "scene"
    shutil.copytree(drivers_scene, scene)
    (scene / damaged).write_bytes((scene / damaged).read_bytes()[:200])
    out = tmp_path / "out.parquet"
    result = invoke(str(scene), "--set", "scenario.lanes=3", "--policy", "keep", "--out", str(out))
    assert result.exit_code == 1 and damaged in result.output and "Traceback" not in result.output, result.output
    assert not out.exists() and not tracks_path(out).exists()


@pytest.mark.parametrize("command", ["evaluate-scene", "recorded-demos"])
@pytest.mark.parametrize(("column", "value"), [("edge", "no_such_edge"), ("lane", 7), ("speed_mps", float("nan"))])
def test_tracks_off_the_scenes_network_or_not_finite_are_a_damaged_scene_in_one_sentence(drivers_scene, tmp_path,
                                                                                          command, column, value):
    """A tracks.parquet that reads but holds a test vehicle on an edge or lane its network lacks, or a value that is
    not a number (hand-edited, or another scene's): one sentence naming the file and the vehicle, exit 1 (was a
    KeyError traceback, or NaN positions carried into the tables)."""
    scene = tmp_path / "scene"
    shutil.copytree(drivers_scene, scene)
    tracks, split = pd.read_parquet(scene / "tracks.parquet"), pd.read_parquet(scene / "split.parquet")
    vehicle = split.loc[split["split"] == "test", "vehicle_id"].iloc[0]
    tracks[column] = tracks[column].astype(object)
    tracks.loc[tracks.index[tracks["vehicle_id"] == vehicle][3], column] = value
    tracks.astype({column: pd.read_parquet(drivers_scene / "tracks.parquet")[column].dtype}).to_parquet(
        scene / "tracks.parquet", index=False)
    out = tmp_path / "out.parquet"
    args = [str(scene), "--set", "scenario.lanes=3", "--split", "test", "--out", str(out)]
    result = (invoke(*args, "--policy", "keep") if command == "evaluate-scene"
              else CliRunner().invoke(cli, ["recorded-demos", *args, *SCENE_SPEED]))
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 1 and len(errors) == 1 and "Traceback" not in result.output, result.output
    assert "tracks.parquet" in errors[0] and f"vehicle {vehicle}" in errors[0] and not out.exists()


@pytest.mark.parametrize("command", ["evaluate-scene", "recorded-demos"])
@pytest.mark.parametrize(("column", "value"), [("split", "banana"), ("vehicle_id", "ghost")])
def test_a_split_file_naming_an_unknown_split_or_a_vehicle_without_a_track_is_a_damaged_scene(
        drivers_scene, tmp_path, command, column, value):
    """Were read silently: a vehicle in none of the three splits, or listed without a track in tracks.parquet
    (hand-edited, another scene's), was never seated nor read."""
    scene = tmp_path / "scene"
    shutil.copytree(drivers_scene, scene)
    split = pd.read_parquet(scene / "split.parquet")
    split.loc[split.index[0], column] = value
    split.to_parquet(scene / "split.parquet", index=False)
    out = tmp_path / "out.parquet"
    args = [str(scene), "--set", "scenario.lanes=3", "--out", str(out)]
    result = (invoke(*args, "--policy", "keep") if command == "evaluate-scene"
              else CliRunner().invoke(cli, ["recorded-demos", *args, *SCENE_SPEED]))
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 1 and len(errors) == 1 and "Traceback" not in result.output, result.output
    assert "split.parquet" in errors[0] and value in errors[0] and not out.exists()


@pytest.mark.parametrize("problem", ["not a scene", "not a network", "no seat", "policy", "other lanes",
                                     "shadowed length", "other interface"])
def test_evaluate_scene_refuses_in_one_sentence_and_writes_nothing(drivers_scene, tmp_path, problem):
    scene, extra, code = drivers_scene, ["--set", "scenario.lanes=3"], 2
    if problem == "not a scene":
        scene = tmp_path / "empty"
        scene.mkdir()
    elif problem == "not a network":
        scene = tmp_path / "damaged"
        shutil.copytree(drivers_scene, scene)
        (scene / "road.net.xml").write_text("<net>")
    elif problem == "no seat":
        extra += ["--horizon-s", "600"]
    elif problem == "other lanes":  # the scene has 3 lanes, the observation 5: a policy would read a wrong layout
        extra = ["--set", "scenario.lanes=5"]
    elif problem == "shadowed length":  # the seat's length is --horizon-s: a different env.max_episode_s is refused
        extra += ["--set", "env.max_episode_s=12"]
    elif problem == "other interface":  # a policy trained on the acceleration interface, this run the paper's
        trained = Config.from_dict({"scenario": {"lanes": 3}, "actions": {"interface": "acceleration"}})
        shape = PolicyShape("linear", len(observation_names(trained)), actions=action_count(trained.actions))
        save_policy(Policy(shape, np.zeros(shape.parameter_count)), tmp_path / "acceleration.npz",
                    {"config": trained.to_dict(), "observation_names": observation_names(trained)})
        extra += ["--policy", str(tmp_path / "acceleration.npz")]
    else:
        (tmp_path / "policy.npz").write_bytes(b"not a policy")
        extra, code = [*extra, "--policy", str(tmp_path / "policy.npz")], 1
    out = tmp_path / "out.parquet"
    result = invoke(str(scene), *extra, "--out", str(out))
    assert result.exit_code == code, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert "Traceback" not in result.output and len(errors) == 1 and errors[0].count(". ") == 0
    assert not out.exists() and not tracks_path(out).exists()
    if problem == "other interface":
        assert "chooses among 111 actions" in errors[0] and "--set actions.interface=acceleration" in errors[0]


class _Braking:
    """Always decelerates (a DriverSpec)."""

    name = "braking"

    def create(self, config, seed):
        return lambda observation, traffic: 2


def test_a_replayed_follower_running_into_a_braking_ego_is_not_the_egos_fault(drivers_scene):
    """Non-reactive: the follower keeps its recorded speed and hits the ego from behind; SUMO names it the collider,
    so the collision counts, but not as the ego's fault (the driving score's gate stays open)."""
    scene = read_scene(drivers_scene)
    config = CONFIG.with_overrides({"env": {"max_episode_s": 20.0}})
    seats = choose_seats(scene, "test", 20.0, 2.0, None, 0) + choose_seats(scene, "train", 20.0, 2.0, None, 0)
    with SerialBackend() as backend:
        metrics = evaluate_seats([_Braking()], ["braking"], config, seats, ["non-reactive", "reactive"], backend,
                                 seed=0).metrics
    replayed, reactive = (metrics[metrics["mode"] == mode] for mode in ("non-reactive", "reactive"))
    assert replayed["collisions"].sum() >= 1 and replayed["at_fault_collisions"].sum() == 0
    hit = replayed[replayed["collisions"] > 0]
    assert (hit["termination"] == "collision").all() and (hit["no_collision"] == 1.0).all()
    assert reactive["collisions"].sum() < replayed["collisions"].sum()  # SUMO's drivers brake for the ego


def cut_in_scene(drivers_scene, folder):
    """Two cars on the drivers scene's road: "human" at 30 m/s in lane 0, and "cutter", beside it in lane 1 until
    1 s, then 0.5 m ahead of it in lane 0 at 5 m/s: whoever sits in the human's seat runs into it."""
    shutil.copytree(drivers_scene, folder)
    road = scene_road(folder / "road.net.xml")
    lane_y_m = [road.net.lane.getShape(f"{road.route[0]}_{lane}")[0][1] for lane in range(road.lanes)]
    rows = []
    for k in range(151):
        time_s = k / 10.0
        human_x = 100.0 + 30.0 * time_s
        cut = time_s >= 1.0
        cutter_x = 100.0 + 30.0 + 5.0 + 5.0 * (time_s - 1.0) if cut else human_x + 8.0
        for vehicle, x, lane, speed in (("human", human_x, 0, 30.0), ("cutter", cutter_x, 0 if cut else 1,
                                                                     5.0 if cut else 30.0)):
            rows.append({"vehicle_id": vehicle, "time_s": time_s, "x_m": x, "y_m": lane_y_m[lane],
                         "heading_deg": 90.0, "speed_mps": speed, "acceleration_mps2": 0.0, "edge": road.route[0],
                         "lane": lane, "lane_position_m": x, "length_m": 4.5, "width_m": 1.8,
                         "vehicle_class": "passenger"})
    pd.DataFrame(rows).astype({"lane": "int16", "length_m": "float32", "width_m": "float32"}).to_parquet(
        folder / "tracks.parquet", index=False)
    pd.DataFrame({"vehicle_id": ["human", "cutter"], "split": ["test", "train"]}).to_parquet(
        folder / "split.parquet", index=False)
    meta = json.loads((folder / "scene.json").read_text())
    (folder / "scene.json").write_text(json.dumps(meta | {"dropped": {}}))
    return folder


def test_running_into_a_vehicle_that_cut_in_is_the_egos_fault(drivers_scene, tmp_path):
    scene = read_scene(cut_in_scene(drivers_scene, tmp_path / "cut_in"))
    seats = choose_seats(scene, "test", 10.0, 0.5, None, 0)
    with SerialBackend() as backend:
        metrics = evaluate_seats([KeepDriver()], ["keep"], CONFIG, seats, ["non-reactive"], backend, seed=0).metrics
    row = metrics.iloc[0]
    assert row["termination"] == "collision" and row["at_fault_collisions"] == 1
    assert row["driving_score"] == 0.0 and row["no_collision"] == 0.0


@pytest.mark.parametrize(("after", "when"), [("sumo_rail.evaluation.protocol:write_evaluation", ""),
                                             ("sumo_rail.evaluation.scene_summary:track_table",
                                              " after the work was done")])
def test_a_sigterm_after_both_outputs_were_written_names_them(drivers_scene, tmp_path, after, when):
    """SIGTERM once both tables are written, in the work or after it (as the summary is printed): the sentence names
    them, not "nothing was written"."""
    out = tmp_path / "scene_eval.parquet"
    result = stopped_after(after, signal.SIGTERM, ["evaluate-scene", str(drivers_scene), *SCENE_SPEED, "--set",
                                                   "scenario.lanes=3", "--set", "observation.lane_block=1", "--policy",
                                                   "keep", "--seats", "1", "--horizon-s", "10", "--lead-s", "2",
                                                   "--mode", "reactive", "--out", str(out)], tmp_path)
    assert result.returncode == 1 and "Traceback" not in result.stderr, result.stderr
    assert result.stderr.splitlines()[-1] == f"Error: interrupted{when}; {out} and {tracks_path(out)} were written"
    assert len(pd.read_parquet(out)) == 1 and len(pd.read_parquet(tracks_path(out))) > 0


def test_a_configuration_below_the_scenes_speed_limit_is_refused(drivers_scene, tmp_path):
    """The seats would cap the ego at 33.33 m/s on a road whose drivers go up to 44.44 m/s and beyond."""
    out = tmp_path / "out.parquet"
    result = CliRunner().invoke(cli, ["evaluate-scene", str(drivers_scene), "--set", "scenario.lanes=3", "--policy",
                                      "keep", "--out", str(out)])
    assert result.exit_code == 2 and "speed limit of 44.44 m/s" in result.output
    assert "--set scenario.speed_limit_mps=44.44 --set env.v_max_mps=44.44" in result.output
    assert "Traceback" not in result.output and not out.exists()


def test_a_policy_word_that_is_no_seat_driver_and_no_file_is_a_usage_error_listing_the_words(drivers_scene, tmp_path):
    """Was exit 1 "policy file bogus does not exist"; the words include those of a seat (sumo-idm-calibrated too)."""
    out = tmp_path / "out.parquet"
    result = invoke(str(drivers_scene), "--set", "scenario.lanes=3", "--policy", "bogus", "--out", str(out))
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 2 and len(errors) == 1 and "Traceback" not in result.output, result.output
    assert "'bogus' is neither a driver word" in errors[0] and "sumo-idm, sumo-idm-calibrated" in errors[0]
    assert not out.exists()
