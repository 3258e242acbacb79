"""A recorded scene as a Gymnasium env: `gymnasium.make(SCENE_ENV_ID, scene=...)` passes Gymnasium's checker, and a
reset without a vehicle seats the ego in a seat of the scene's split drawn by the seed (the seats evaluate-scene
chooses), so vector envs and Stable-Baselines3 drive it as they drive the generated road."""

from __future__ import annotations

import re

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sumo_rail
from sumo_rail.config import Config
from sumo_rail.recordings.scene import read_scene
from sumo_rail.recordings.scene_drivers import reactive_types
from sumo_rail.recordings.scene_observations import scene_road
from sumo_rail.recordings.seats import choose_seats

CONFIG = {"observation": {"lane_block": 1}, "env": {"max_episode_s": 8.0}, "actions": {"interface": "acceleration"}}


@pytest.fixture(scope="module")
def scene_env(drivers_scene):
    env = gymnasium.make(sumo_rail.SCENE_ENV_ID, scene=drivers_scene, config=CONFIG, lead_s=2.0)
    yield env
    env.close()


def test_the_scene_env_passes_gymnasiums_checker(scene_env):
    check_env(scene_env.unwrapped, skip_render_check=True)


def test_a_reset_by_seed_alone_seats_the_ego_in_a_seat_of_the_split_drawn_by_the_seed(scene_env, drivers_scene):
    seats = {(seat.vehicle, seat.start_s) for seat in choose_seats(read_scene(drivers_scene), "train", 8.0, 2.0,
                                                                   None, 0, earliest_s=0.1)}
    drawn = {}
    for seed in range(8):
        observation, info = scene_env.reset(seed=seed)
        drawn[seed] = (info["vehicle"], info["start_s"], observation)
    assert {(vehicle, start_s) for vehicle, start_s, _ in drawn.values()} <= seats
    assert len({vehicle for vehicle, _, _ in drawn.values()}) >= 3  # drawn, not always the first seat
    observation, info = scene_env.reset(seed=5)
    assert (info["vehicle"], info["start_s"]) == drawn[5][:2] and np.array_equal(observation, drawn[5][2])
    vehicle, start_s, _ = drawn[5]
    chosen, chosen_info = scene_env.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
    assert chosen_info["vehicle"] == vehicle and np.array_equal(chosen, drawn[5][2])  # the same seat, named


def test_a_scene_without_a_seat_that_fits_is_one_sentence(drivers_scene):
    env = gymnasium.make(sumo_rail.SCENE_ENV_ID, scene=drivers_scene,
                         config={**CONFIG, "env": {"max_episode_s": 600.0}})
    with pytest.raises(ValueError, match=r"no train-split car of the scene .* has a track covering the seat's "
                                         r"lead-in 5 s and env.max_episode_s 600 s$"):
        env.reset(seed=0)
    env.close()



def test_over_traci_a_seat_earlier_than_the_last_is_the_seat_libsumo_gives(scene_env, drivers_scene):
    """SUMO over TraCI (a second env of a process, sumo-gui) keeps the last load's clock when a load begins earlier;
    the ego's seat and the replayed vehicles are those of the seat's instant nevertheless."""
    seats = choose_seats(read_scene(drivers_scene), "train", 8.0, 2.0, None, 0, earliest_s=0.1)
    early, late = (min(seats, key=lambda seat: seat.start_s), max(seats, key=lambda seat: seat.start_s))
    assert late.start_s - early.start_s > 5.0
    options = {"vehicle": early.vehicle, "start_s": early.start_s}
    expected, _ = scene_env.reset(seed=1, options=options)  # libsumo
    env = gymnasium.make(sumo_rail.SCENE_ENV_ID, scene=drivers_scene, config=CONFIG, lead_s=2.0, transport="traci")
    try:
        env.reset(seed=1, options={"vehicle": late.vehicle, "start_s": late.start_s})
        observation, _ = env.reset(seed=1, options=options)
        assert env.unwrapped.simulation.time_s == pytest.approx(early.start_s)
        assert np.array_equal(observation, expected)
    finally:
        env.close()


@pytest.mark.parametrize("start_s", [float("nan"), float("inf")])
def test_a_start_that_is_no_finite_time_is_refused_before_sumo_loads(scene_env, start_s):
    """SUMO would be asked to begin at it (over TraCI its process quits, and the env with it)."""
    vehicle = scene_env.reset(seed=0)[1]["vehicle"]
    with pytest.raises(ValueError, match=r"^reset option 'start_s' must be a time at least one SUMO step \(0.1 s\) "
                                         r"into the scene, got (nan|inf)$"):
        scene_env.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
    assert scene_env.reset(seed=0)[1]["vehicle"] == vehicle  # the env goes on


def test_the_documented_make_without_a_config_seats_the_ego_for_evaluate_scenes_default_horizon(drivers_scene):
    """`gymnasium.make(SCENE_ENV_ID, scene=FOLDER)` then `reset(seed=...)` (README): the default config on the scene's
    road, its episodes evaluate-scene's default 15 s (the generated road's 300 s outlasts every track: no seat to
    draw); a chosen env.max_episode_s, or `horizon_s`, is kept."""
    env = gymnasium.make(sumo_rail.SCENE_ENV_ID, scene=drivers_scene)
    try:
        assert env.unwrapped.config.env.max_episode_s == 15.0 and env.unwrapped.config.scenario.kind == "network"
        assert env.reset(seed=0)[1]["vehicle"] is not None
    finally:
        env.close()
    chosen = [gymnasium.make(sumo_rail.SCENE_ENV_ID, scene=drivers_scene, **kwargs) for kwargs in
              ({"config": {"env": {"max_episode_s": 8.0}}}, {"horizon_s": 300.0})]
    assert [env.unwrapped.config.env.max_episode_s for env in chosen] == [8.0, 300.0]
    for env in chosen:
        env.close()


def test_over_traci_an_ego_gone_in_a_collision_leaves_no_sumo_error_on_the_terminal(drivers_scene, capfd):
    """Braking as hard as the interface allows, the ego is run into by replayed followers; the stepping learns it is
    gone by asking for it, which SUMO answers with an error that it used to print ("Error: Answered with error to
    command 0xa4: Vehicle 'ego' is not known.") for every such episode of a second env of a process."""
    env = gymnasium.make(sumo_rail.SCENE_ENV_ID, scene=drivers_scene, config=CONFIG, lead_s=2.0, transport="traci")
    endings = []
    try:
        for seed in range(6):
            env.reset(seed=seed)
            terminated = truncated = False
            while not (terminated or truncated):
                _, _, terminated, truncated, info = env.step(0)
            endings.append(info["termination"])
    finally:
        env.close()
    assert "collision" in endings and "Error" not in capfd.readouterr().err


def test_the_scene_env_drives_at_its_roads_limit_and_its_reactive_vehicles_as_evaluate_scene_does(drivers_scene):
    """The env takes the scene's road as it takes its lanes: a configuration below the road's speed limit (the
    defaults' 33.33 m/s on a 44.44 m/s road) drives at that limit, with its top set-point not below it, as the
    commands require; and reactive, by default its vehicles drive what evaluate-scene gives them (their recorded
    vTypes, else the IDM calibrated on the train split), not SUMO's default Krauss."""
    scene = read_scene(drivers_scene)
    limit = scene_road(scene.network).speed_limit_mps
    assert limit > Config().scenario.speed_limit_mps + 1.0  # the case: a road faster than the defaults
    env = gymnasium.make(sumo_rail.SCENE_ENV_ID, scene=drivers_scene, reactive=True)
    try:
        config = env.unwrapped.config
        assert config.scenario.speed_limit_mps == limit and config.env.v_max_mps >= limit
        expected = reactive_types(scene, config.scenario.step_length_s).types
        assert env.unwrapped.core.start.types == expected and expected.of_vehicle
    finally:
        env.close()


@pytest.mark.parametrize(("kwargs", "said"), [({"split": "banana"}, "unknown split 'banana'"),
                                              ({"lead_s": -1.0}, "lead_s must be a finite number of at least 0"),
                                              ({"zone_m": float("nan")}, "zone_m must be a finite number")])
def test_a_split_lead_in_or_zone_the_env_cannot_seat_by_is_one_sentence_when_it_is_made(drivers_scene, kwargs, said):
    """Was: an unknown split said "no banana-split car ..." at the first reset, and a negative lead-in seated the ego
    before its car's track began ("vehicle ... is not on the road")."""
    with pytest.raises(ValueError, match=f"^{re.escape(said)}"):
        gymnasium.make(sumo_rail.SCENE_ENV_ID, scene=drivers_scene, **kwargs)
