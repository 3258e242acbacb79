"""The acceleration interface in a recorded seat: the ego keeps the seated vehicle's size and follows its commands."""

from __future__ import annotations

import numpy as np
import pytest

from sumo_rail.config import Config
from sumo_rail.recordings.seat import SceneEnv
from sumo_rail.sim.actions import Lateral, acceleration_action
from sumo_rail.sim.observation import acceleration_slot, control_slot
from sumo_rail.sim.simulation import EGO_ID

CONFIG = Config.from_dict({"observation": {"lane_block": 1}, "env": {"max_episode_s": 10.0},
                           "actions": {"interface": "acceleration"}})


def longest_track(tracks, vehicle_class):
    """The longest-lasting track of `vehicle_class` and the instant 1 s into it."""
    spans = tracks[tracks["vehicle_class"] == vehicle_class].groupby("vehicle_id")["time_s"].agg(["min", "max"])
    vehicle = (spans["max"] - spans["min"]).idxmax()
    return str(vehicle), float(spans.at[vehicle, "min"] + 1.0)


@pytest.fixture(scope="module")
def replay(drivers_scene):
    env = SceneEnv(CONFIG, drivers_scene, reactive=False)
    yield env
    env.close()


def test_a_seated_truck_keeps_its_size_under_the_acceleration_interface(replay):
    tracks = replay.scene.tracks
    vehicle, start_s = longest_track(tracks, "truck")
    replay.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
    recorded = tracks[tracks["vehicle_id"] == vehicle].iloc[0]
    sumo = replay.simulation._api.vehicle  # what SUMO itself drives (the env's view caches sizes)
    assert sumo.getLength(EGO_ID) == pytest.approx(recorded["length_m"])
    assert sumo.getWidth(EGO_ID) == pytest.approx(recorded["width_m"])
    assert replay.traffic.ego.length_m == pytest.approx(recorded["length_m"])
    assert recorded["length_m"] > 6.0  # a truck's, not the acceleration type's 4.5 m


def test_the_seat_follows_a_commanded_braking(replay):
    vehicle, start_s = longest_track(replay.scene.tracks, "passenger")
    _, info = replay.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
    actions = replay.unwrapped.config.actions
    speed = info["speed_mps"]
    _, _, _, _, info = replay.step(acceleration_action(actions.nearest_bin(-2.0), Lateral.KEEP, actions))
    assert info["speed_mps"] == pytest.approx(speed - 1.0, abs=1e-6)


def test_the_seats_history_is_the_recorded_lead_in(drivers_scene):
    """With observation.history, the first observation in a seat shows the human's speed 1, 2 and 3 s before it."""
    config = CONFIG.with_overrides({"observation": {"history": 3}})
    env = SceneEnv(config, drivers_scene, reactive=False)
    try:
        tracks = env.scene.tracks
        vehicle, start_s = longest_track(tracks, "passenger")
        start_s += 4.0
        observation, _ = env.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
        track = tracks[tracks["vehicle_id"] == vehicle].set_index("time_s")
        block = observation[-9:]
        for k in (1, 2, 3):
            row = track.loc[min(track.index, key=lambda t: abs(t - (start_s - k)))]
            assert block[3 * (k - 1)] == pytest.approx(row["speed_mps"] / env.config.env.v_max_mps, abs=1e-5)
            assert block[3 * (k - 1) + 1] == pytest.approx(row["acceleration_mps2"] / 9.0, abs=1e-5)
    finally:
        env.close()


def test_the_first_observation_shows_the_lead_ins_last_period_as_the_demonstrations_do(replay):
    """Before its first decision the seated ego's last commanded acceleration is the human's over the period before
    the seat, in its bin (what recorded-demos shows at that instant), not 0: a policy that learned to go on as the
    last command did would otherwise start every seat by holding its speed."""
    tracks = replay.scene.tracks
    vehicle, first_s = longest_track(tracks, "passenger")
    track = tracks[tracks["vehicle_id"] == vehicle]
    time_s, speed = track["time_s"].to_numpy(), track["speed_mps"].to_numpy()
    config = replay.unwrapped.config
    actions, period = config.actions, config.env.decision_period_s
    instants = first_s + period * np.arange(2, 40)
    accelerations = (np.interp(instants, time_s, speed) - np.interp(instants - period, time_s, speed)) / period
    chosen = int(np.argmax(np.abs(accelerations)))
    start_s, shown = float(instants[chosen]), actions.acceleration_mps2(actions.nearest_bin(accelerations[chosen]))
    assert abs(shown) >= 0.5  # a seat whose human was changing speed
    observation, _ = replay.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
    assert observation[control_slot(config)] == pytest.approx(acceleration_slot(shown, actions), abs=1e-6)
