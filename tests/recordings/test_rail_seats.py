"""RAIL with its rollouts in a recorded scene's train-split seats (`rail.rollout_seats`): end to end on the two-car
scene, both signs of a direction on the same seats, the same weights whatever the number of workers, and the
refusals before any work."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from sumo_rail_cli import commands
from test_recorded_demos import SMALL, invoke, two_car_scene

from sumo_rail.config import Config
from sumo_rail.drivers.policies import Policy, PolicyShape, load_policy
from sumo_rail.learning.rail import seat_rollouts
from sumo_rail.learning.rail.iteration import RailSettings
from sumo_rail.learning.rail.seat_rollouts import InSeats, SeatRolloutTask, rail_seats
from sumo_rail.learning.train_seats import SceneSeatsError, TrainSeats
from sumo_rail.recordings.seats import Seat
from sumo_rail.runners import rollout
from sumo_rail.runners.backends import SerialBackend

ACCELERATION = ("--set", "actions.interface=acceleration")
SEATS = ("--set", "rail.rollout_seats=2", "--set", "rail.seat_lead_s=0.5", "--set", "env.max_episode_s=3")
RUN = ("--iterations", "2", "--set", "rail.directions=2", "--set", "rail.top=1", "--set", "bc.epochs=1",
       "--eval-every", "0")


@pytest.fixture(scope="module")
def scene_and_demos(tmp_path_factory):
    """The two-car scene, all train (one passenger car's seat), and its demonstrations on the acceleration
    interface."""
    folder = tmp_path_factory.mktemp("rail_seats")
    two_car_scene(folder / "scene")
    demos = folder / "demos.parquet"
    result = invoke("recorded-demos", str(folder / "scene"), *ACCELERATION, "--out", str(demos))
    assert result.exit_code == 0, result.output
    return folder / "scene", demos


def train(demos, out, *extra: str):
    result = invoke("train", *SMALL, *ACCELERATION, *SEATS, "--demos", str(demos), *RUN, *extra, "--out", str(out))
    assert result.exit_code == 0, result.output
    return pd.read_parquet(out / "log.parquet")


def seated_episodes(monkeypatch) -> list[tuple[str, dict]]:
    """What every rollout episode run in this process is given from now on: (its env's class, its reset options);
    and the train command runs its rollouts in this process."""
    seated = []

    def run_episode(env, driver, seed, record=False, options=None):
        seated.append((type(env).__name__, options))
        return rollout.run_episode(env, driver, seed, record, options)
    monkeypatch.setattr(seat_rollouts, "run_episode", run_episode)
    monkeypatch.setattr(commands, "build_backend", lambda *args: SerialBackend())
    return seated


def test_rail_in_seats_drives_the_scenes_seat(scene_and_demos, tmp_path, monkeypatch):
    """Each iteration's 2 directions x 2 signs x 2 seats are episodes in the car's seat, 3 s from 0.5 s into its
    track at 0.5 s decisions (6 decisions each), and the policy moves from BC."""
    _, demos = scene_and_demos
    seated = seated_episodes(monkeypatch)
    log = train(demos, tmp_path / "run")
    assert seated == [("SceneEnv", {"vehicle": "car", "start_s": 0.5})] * (2 * 2 * 2 * 2)
    assert log["env_steps"].tolist() == [2 * 2 * 2 * 6] * 2 and log["collisions"].tolist() == [0, 0]
    latest, _ = load_policy(tmp_path / "run" / "policy_latest.npz")
    bc, _ = load_policy(tmp_path / "run" / "policy_bc.npz")
    assert not np.array_equal(latest.parameters, bc.parameters)


def test_rail_in_seats_gives_the_same_weights_in_one_process_and_on_two_workers(drivers_scene, tmp_path,
                                                                                monkeypatch):
    """On SUMO's drivers' scene (30 train seats), the directions drive other seats, and the run is the same."""
    demos = tmp_path / "demos.parquet"
    lanes = ("--set", "scenario.lanes=3")
    result = invoke("recorded-demos", str(drivers_scene), *lanes, *ACCELERATION, "--split", "train", "--out",
                    str(demos))
    assert result.exit_code == 0, result.output
    seated = seated_episodes(monkeypatch)
    serial = train(demos, tmp_path / "one", *lanes)
    assert len({options["vehicle"] for _, options in seated}) > 2
    monkeypatch.undo()
    pooled = train(demos, tmp_path / "two", *lanes, "--workers", "2")
    pd.testing.assert_frame_equal(serial.drop(columns="wall_time_s"), pooled.drop(columns="wall_time_s"))
    one, _ = load_policy(tmp_path / "one" / "policy_latest.npz")
    two, _ = load_policy(tmp_path / "two" / "policy_latest.npz")
    assert np.array_equal(one.parameters, two.parameters)


class _Recorded:
    """A backend that keeps the tasks it is given and answers each with one empty trajectory list."""

    def __init__(self) -> None:
        self.tasks: list[SeatRolloutTask] = []

    def run(self, tasks, on_result=None):
        self.tasks.extend(tasks)
        return [[[]] for _ in tasks]


def drawn_tasks(settings: RailSettings, iteration: int) -> list[SeatRolloutTask]:
    """The tasks of one iteration of `InSeats` over ten seats."""
    seats = TrainSeats(Config(), None, tuple(Seat("scene", f"car{k}", float(k)) for k in range(10)))
    shape = PolicyShape("linear", 4, 0, 5)
    backend = _Recorded()
    InSeats(seats)(Policy(shape, np.zeros(shape.parameter_count, np.float32)), settings, iteration, 0.1, None,
                   backend, None)
    return backend.tasks


def test_both_signs_of_a_direction_drive_the_same_seats_from_the_same_seeds():
    """The antithetic pair differs by its sign only; directions and iterations draw other seats."""
    settings = RailSettings(directions=6, rollout_seats=3, seed=4)
    tasks = drawn_tasks(settings, iteration=0)
    assert [task.member for task in tasks] == [(k, sign) for k in range(6) for sign in (1, -1)]
    for plus, minus in zip(tasks[0::2], tasks[1::2], strict=True):
        assert plus.seats == minus.seats and plus.episode_seeds == minus.episode_seeds
        assert len(set(plus.seats)) == 3  # without replacement
    assert len({task.seats for task in tasks}) > 1
    assert {task.seats for task in tasks} != {task.seats for task in drawn_tasks(settings, iteration=1)}
    common = drawn_tasks(RailSettings(directions=6, rollout_seats=3, seed=4, common_traffic=True), iteration=0)
    assert len({(task.seats, task.episode_seeds) for task in common}) == 1


def test_rail_seats_need_a_scenes_demonstrations():
    with pytest.raises(SceneSeatsError, match=r"demos\.parquet were not read from a recorded scene"):
        rail_seats(RailSettings(rollout_seats=1), {}, "demos.parquet", Config())
    assert rail_seats(RailSettings(), {}, "demos.parquet", Config()) is None  # the generated road: no scene asked


@pytest.mark.parametrize(("extra", "gone", "message"), [
    (("--set", "rail.seat_zone_m=500"), None, "has a track of rail.seat_lead_s + env.max_episode_s = 3.5 s with "
                                              "rail.seat_zone_m = 500 m"),
    ((), "tracks.parquet", "cannot be read"),
    (("--set", "rail.egos=2"), None, "rail.rollout_seats drives each rollout in its own seats"),
])
def test_rail_in_seats_refuses_in_one_sentence_before_any_work(tmp_path, extra, gone, message):
    two_car_scene(tmp_path / "scene")
    demos = tmp_path / "demos.parquet"
    assert invoke("recorded-demos", str(tmp_path / "scene"), *ACCELERATION, "--out", str(demos)).exit_code == 0
    if gone is not None:
        (tmp_path / "scene" / gone).unlink()
    result = invoke("train", *SMALL, *ACCELERATION, *SEATS, "--demos", str(demos), *RUN, *extra,
                    "--out", str(tmp_path / "run"))
    assert result.exit_code == 2 and message in result.output, result.output
    assert "Traceback" not in result.output and not (tmp_path / "run").exists()
