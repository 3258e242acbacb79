"""GAIL in a recorded scene's seats (gail.in_seats): its env processes drive the train-split seats of the scene the
demonstrations were read from, with SB3's auto-reset semantics, and the command refuses what cannot be driven."""

from __future__ import annotations

import numpy as np
import pytest
from test_recorded_demos import SMALL, invoke

from sumo_rail.config import Config
from sumo_rail.datasets import read_metadata
from sumo_rail.learning.sb3.seat_road import SceneSeats, SeatRoad

ACCELERATION = ("--set", "actions.interface=acceleration")
SEAT = ("--set", "env.max_episode_s=3", "--set", "gail.seat_lead_s=0.5")


def seat_config(scene) -> Config:
    return Config.from_dict({"actions": {"interface": "acceleration"}, "env": {"max_episode_s": 3.0, "v_max_mps": 50},
                             "scenario": {"speed_limit_mps": 44.44}})


def test_a_seat_road_drives_seat_after_seat_as_sb3s_auto_reset_does(scene_and_demos):
    scene, demos = scene_and_demos
    config = seat_config(scene)
    seats = SceneSeats.of_demonstrations(read_metadata(demos), demos, config, 0.5, 0.0)
    runs = []
    for _ in range(2):
        road = SeatRoad(config, seats, seed=7)
        try:
            first = road.reset()
            steps, ends = [], []
            for _ in range(8):  # 3 s at 0.5 s: the seat's episode ends at its 6th decision
                observation, reward, done, info = road.step([0])
                steps.append(observation.copy())
                if done[0]:
                    ends.append(info[0])
        finally:
            road.close()
        runs.append((first, steps, ends))
    (first, steps, ends), (again, steps_again, _) = runs
    assert first.shape == (1, steps[0].shape[1]) and reward.dtype == np.float64
    assert len(ends) == 1 and "terminal_observation" in ends[0] and ends[0]["TimeLimit.truncated"]
    assert np.array_equal(first, again) and all(np.array_equal(a, b) for a, b in zip(steps, steps_again, strict=True))
    assert np.array_equal(steps[5], first)  # the car's only train seat again, from its start


def test_the_env_processes_drive_the_seats_they_are_given(scene_and_demos, tmp_path):
    pytest.importorskip("stable_baselines3", reason="gail is the package's optional extra [baselines]")
    from sumo_rail.learning.sb3.driving_envs import driving_processes
    from sumo_rail.learning.sb3.shared_road import env_seeds

    scene, demos = scene_and_demos
    config = seat_config(scene)
    seats = SceneSeats.of_demonstrations(read_metadata(demos), demos, config, 0.5, 0.0)
    venv = driving_processes(config, 1, 1, 3, tmp_path, seats)
    try:
        first = venv.reset()
    finally:
        venv.close()
    road = SeatRoad(config, seats, env_seeds(3, 1)[0])
    try:
        assert np.array_equal(first, road.reset())
    finally:
        road.close()


def test_gail_learns_in_the_scenes_seats(scene_and_demos, tmp_path, monkeypatch):
    pytest.importorskip("stable_baselines3", reason="gail is the package's optional extra [baselines]")
    from sumo_rail.learning.sb3 import gail

    scene, demos = scene_and_demos
    asked, processes = [], gail.driving_processes
    monkeypatch.setattr(gail, "driving_processes", lambda *args: asked.append(args[-1]) or processes(*args))
    run = tmp_path / "gail"
    result = invoke("gail", *SMALL, *ACCELERATION, *SEAT, "--demos", str(demos), "--timesteps", "24", "--set",
                    "gail.n_steps=12", "--set", "gail.envs=2", "--set", "gail.critic_warmup=0", "--set",
                    "gail.in_seats=true", "--set", "bc.epochs=1", "--out", str(run))
    assert result.exit_code == 0, result.output
    assert (run / "policy_latest.npz").exists() and (run / "log.parquet").exists()
    assert asked == [SceneSeats(str(scene), 0.5, 0.0)]  # its env processes drove the scene's seats


@pytest.mark.parametrize("problem", ["generated demonstrations", "egos", "no seat"])
def test_gail_in_seats_refuses_what_cannot_be_driven_before_any_work(scene_and_demos, demos_path, tmp_path, problem):
    pytest.importorskip("stable_baselines3", reason="gail is the package's optional extra [baselines]")
    _, demos = scene_and_demos
    extra, message = [], "no train-split car of the scene"
    if problem == "generated demonstrations":
        demos, extra, message = demos_path, [], "were not read from a recorded scene"
    elif problem == "egos":
        extra, message = ["--set", "gail.egos=2"], "gail.in_seats drives one ego in each seat"
    else:
        extra = ["--set", "gail.seat_lead_s=3"]
    run = tmp_path / "gail"
    options = [*SMALL, *SEAT] if problem != "generated demonstrations" else ["--set", "gail.in_seats=true"]
    result = invoke("gail", *options, *(ACCELERATION if problem != "generated demonstrations" else ()), "--demos",
                    str(demos), "--timesteps", "24", "--set", "gail.n_steps=12", "--set", "gail.in_seats=true",
                    *extra, "--out", str(run))
    assert result.exit_code == 2 and message in result.output and "Traceback" not in result.output, result.output
    assert not run.exists()
