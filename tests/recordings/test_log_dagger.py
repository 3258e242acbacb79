"""DAgger against the log (`dagger --expert log`): the learner drives in the scene's train-split seats, each state
labelled by the log teacher; on the human's own track the labels are its read actions, off it they steer back."""

from __future__ import annotations

import numpy as np
import pyarrow.parquet as pq
import pytest
from test_recorded_demos import SMALL, invoke, two_car_scene

from sumo_rail.config import Config
from sumo_rail.datasets import read_metadata
from sumo_rail.drivers.policies import Policy, PolicyShape, load_policy
from sumo_rail.learning.log_dagger import LogDaggerTask, LogSeats
from sumo_rail.recordings.scene import read_scene
from sumo_rail.recordings.tracks import RecordingUsageError
from sumo_rail.runners.backends import SerialBackend
from sumo_rail.sim.actions import Lateral, acceleration_action, split_acceleration_action
from sumo_rail.sim.observation import observation_space

ACCELERATION = ("--set", "actions.interface=acceleration")
SEATS = ("--set", "dagger.seat_lead_s=0.5", "--set", "dagger.seat_s=3")
CONFIG = Config.from_dict({"actions": {"interface": "acceleration"}, "scenario": {"speed_limit_mps": 44.44},
                           "env": {"v_max_mps": 44.44}})


def constant_policy(action: int) -> Policy:
    """A linear policy that always chooses `action`."""
    shape = PolicyShape("linear", observation_space(CONFIG).shape[0], 0, 3 * CONFIG.actions.acceleration_bins)
    parameters = np.zeros(shape.parameter_count, np.float32)
    parameters[shape.actions * shape.observation_size + action] = 1.0  # the bias: only the action's is non-zero
    return Policy(shape, parameters)


def car_episode(demos, policy: Policy, beta: float):
    seats = LogSeats.of(read_metadata(demos), str(demos), CONFIG, 0.5, 3.0, 3.0)
    car = [seat.vehicle for seat in seats.seats].index("car")
    with SerialBackend() as backend:
        episode, = backend.run([LogDaggerTask(seats.config, policy, seats.seats[car], seats.humans[car], 3.0, beta,
                                              7)])
    return episode


def test_driving_the_teachers_labels_gives_the_humans_read_actions(scene_and_demos):
    """beta 1: the teacher drives from the human's state, so the ego stays on the track and every label is the
    action read off the track at that instant (hold 25 m/s until 2 s, then +2 m/s^2), until SUMO's safe speed (the
    ego's emergency brake, Krauss with tau 1 s) holds it back behind the truck 28 m ahead, which the recorded car
    approached closer: from then on the ego falls behind and the labels ask for more than the human's +2 m/s^2."""
    _, demos = scene_and_demos
    episode = car_episode(demos, constant_policy(0), beta=1.0)
    actions = CONFIG.actions
    hold, speed_up = (acceleration_action(actions.nearest_bin(a), Lateral.KEEP, actions) for a in (0.0, 2.0))
    assert episode.labels.tolist()[:4] == [hold] * 3 + [speed_up]  # decisions at 0.5, 1, 1.5 and 2 s
    assert all(split_acceleration_action(int(label), actions) > (actions.nearest_bin(2.0), Lateral.KEEP)
               for label in episode.labels[4:])
    assert episode.policy_decisions == 0


def test_a_learner_that_brakes_is_labelled_to_speed_up_back_to_the_track(scene_and_demos):
    """beta 0: the learner brakes at -2 m/s^2 throughout; it falls behind and below the human's speed, so the labels
    ask for more acceleration than the human's own, more the further it falls behind."""
    _, demos = scene_and_demos
    actions = CONFIG.actions
    brake = acceleration_action(actions.nearest_bin(-2.0), Lateral.KEEP, actions)
    episode = car_episode(demos, constant_policy(brake), beta=0.0)
    assert episode.policy_decisions == len(episode.labels) == 6
    accelerations = [actions.acceleration_mps2(split_acceleration_action(int(a), actions)[0]) for a in episode.labels]
    human = [0.0] * 3 + [2.0] * 3
    assert accelerations[0] == 0.0  # the seat: on the human's state
    assert all(a > h for a, h in zip(accelerations[1:], human[1:], strict=True))
    assert accelerations[2] > accelerations[1]


def test_dagger_against_the_log_aggregates_the_learners_labelled_states(scene_and_demos, tmp_path):
    _, demos = scene_and_demos
    result = invoke("dagger", *SMALL, *ACCELERATION, *SEATS, "--demos", str(demos), "--expert", "log", "--rounds",
                    "1", "--set", "dagger.episodes_per_round=2", "--set", "bc.epochs=1", "--eval-every", "0",
                    "--set", "actions.decoding=expected", "--out", str(tmp_path / "run"))
    assert result.exit_code == 0, result.output
    for name in ("policy_bc.npz", "policy_latest.npz"):  # the run's decoding, in its rollouts and its files
        assert load_policy(tmp_path / "run" / name)[0].shape.decoding == "expected"
    dataset = pq.read_table(tmp_path / "run" / "dataset.parquet")
    episodes = np.array(dataset.column("episode").to_pylist())
    assert len(episodes) == 16 + 2 * 6  # the 16 demonstrations, 6 decisions in each of 2 seats
    assert len(set(episodes[16:])) == 2
    assert read_metadata(tmp_path / "run" / "dataset.parquet")["expert"] == "log"


@pytest.mark.parametrize(("extra", "message"), [
    ((), "needs --set actions.interface=acceleration"),
    ((*ACCELERATION, "--set", "dagger.seat_s=30"), "has a track of dagger.seat_lead_s + dagger.seat_s = 30.5 s"),
])
def test_the_log_teacher_refuses_in_one_sentence(scene_and_demos, tmp_path, extra, message):
    _, demos = scene_and_demos
    result = invoke("dagger", *SMALL, "--set", "dagger.seat_lead_s=0.5", *extra, "--demos", str(demos), "--expert",
                    "log", "--rounds", "1", "--eval-every", "0", "--out", str(tmp_path / "run"))
    assert result.exit_code == 2 and message in result.output, result.output
    assert "Traceback" not in result.output and not (tmp_path / "run").exists()


def test_the_log_teacher_needs_a_scenes_demonstrations(scene_and_demos):
    scene, demos = scene_and_demos
    with pytest.raises(ValueError, match="were not read from a recorded scene"):
        LogSeats.of({}, "demos.parquet", CONFIG, 0.5, 3.0, 3.0)
    assert read_scene(scene).folder == scene
    with pytest.raises(RecordingUsageError, match="lanes"):
        LogSeats.of(read_metadata(demos), str(demos), Config.from_dict({**CONFIG.to_dict(),
                                                                         "scenario": {"lanes": 3}}), 0.5, 3.0, 3.0)


def test_a_scene_changed_since_its_demonstrations_were_read_is_refused(tmp_path):
    two_car_scene(tmp_path / "scene")
    demos = tmp_path / "demos.parquet"
    assert invoke("recorded-demos", str(tmp_path / "scene"), *ACCELERATION, "--out", str(demos)).exit_code == 0
    two_car_scene(tmp_path / "scene", lanes=5)  # written again: the same tracks, so the same bytes
    assert LogSeats.of(read_metadata(demos), str(demos), CONFIG, 0.5, 3.0, 3.0).seats
    meta = tmp_path / "scene" / "scene.json"
    meta.write_text(meta.read_text() + "\n")  # one byte more, the same scene read
    result = invoke("dagger", *SMALL, *ACCELERATION, *SEATS, "--demos", str(demos), "--expert", "log", "--rounds",
                    "1", "--eval-every", "0", "--out", str(tmp_path / "run"))
    assert result.exit_code == 2 and "has changed since" in result.output and not (tmp_path / "run").exists()
