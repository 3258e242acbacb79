"""The ego in a recorded driver's seat: it starts in the human's state, the other vehicles follow the recording
exactly (non-reactive) or react to the ego (reactive), and SUMO can drive the seat itself."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace
from unittest.mock import patch

import numpy as np
import pandas as pd
import pytest

from sumo_rail.config import Config
from sumo_rail.datasets import DatasetError
from sumo_rail.recordings.scene import TRACK_COLUMNS, read_scene
from sumo_rail.recordings.scene_observations import SceneFrames, scene_road
from sumo_rail.recordings.seat import SceneEnv, SeatStart
from sumo_rail.recordings.seats import SeatDraw
from sumo_rail.recordings.trajectory import track_past
from sumo_rail.sim import replay as replayed_traffic
from sumo_rail.sim.actions import Action
from sumo_rail.sim.commands import LANE_CHANGE_MODE_SUMO
from sumo_rail.sim.controllers import SUMO_DRIVER_TYPE
from sumo_rail.sim.replay import REPLAY_RADIUS_M
from sumo_rail.sim.simulation import EGO_ID

CONFIG = Config.from_dict({"observation": {"lane_block": 1}, "env": {"max_episode_s": 10.0}})


def recorded(tracks: pd.DataFrame, time_s: float) -> pd.DataFrame:
    return tracks[np.isclose(tracks["time_s"], time_s)].set_index("vehicle_id")


def long_track(tracks: pd.DataFrame, lane: int | None = None) -> tuple[str, float]:
    """A car on the road for at least 15 s (in `lane` at its start), and the instant 2 s into its track."""
    spans = tracks.groupby("vehicle_id").agg(begin=("time_s", "min"), end=("time_s", "max"),
                                             kind=("vehicle_class", "first"))
    for vehicle, row in spans[(spans["end"] - spans["begin"] >= 15) & (spans["kind"] == "passenger")].iterrows():
        start = recorded(tracks, row["begin"] + 2.0)
        if lane is None or start.at[vehicle, "lane"] == lane:
            return str(vehicle), float(row["begin"] + 2.0)
    raise AssertionError("no such track in the scene")


@pytest.fixture(scope="module")
def replay(drivers_scene):
    env = SceneEnv(CONFIG, drivers_scene, reactive=False)
    yield env
    env.close()


def test_the_ego_starts_in_the_humans_state(replay):
    tracks = replay.scene.tracks
    vehicle, start_s = long_track(tracks)
    replay.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
    human = recorded(tracks, start_s).loc[vehicle]
    ego = replay.traffic.ego
    assert ego.lane == human["lane"]
    assert ego.lane_position_m == pytest.approx(human["lane_position_m"], abs=1e-6)
    assert ego.speed_mps == pytest.approx(human["speed_mps"], abs=1e-6)
    assert ego.length_m == pytest.approx(human["length_m"])
    assert vehicle not in replay.traffic.neighbours.ids  # the human's own vehicle is left out


def test_replayed_vehicles_are_where_the_recording_has_them_whatever_the_ego_does(replay):
    tracks = replay.scene.tracks
    vehicle, start_s = long_track(tracks)
    replay.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
    api = replay.simulation._api
    cut = tracks.groupby("vehicle_id")["time_s"].max()
    far = 0
    for k, action in enumerate([Action.DECELERATE] * 6 + [Action.LANE_LEFT] + [Action.ACCELERATE] * 6):
        _, _, terminated, truncated, _ = replay.step(int(action))
        time_s = start_s + (k + 1) * CONFIG.env.decision_period_s
        frame = recorded(tracks, time_s).drop(index=vehicle, errors="ignore")
        on_road = set(api.vehicle.getIDList()) - {EGO_ID}
        if EGO_ID in api.vehicle.getIDList():  # those within the replay radius of the ego (it moved in the step)
            away = np.abs(frame["x_m"] - api.vehicle.getPosition(EGO_ID)[0])
            inside, outside = set(frame.index[away < REPLAY_RADIUS_M - 5]), set(frame.index[away < REPLAY_RADIUS_M + 5])
            assert inside <= on_road <= outside
            far += int((away >= REPLAY_RADIUS_M + 5).sum())
        else:
            assert on_road == set(frame.index)  # entered and left as recorded (one track ends mid-road at 5 s)
        for other in on_road:
            x, y = api.vehicle.getPosition(other)
            assert np.hypot(x - frame.at[other, "x_m"], y - frame.at[other, "y_m"]) < 1e-3
        if terminated or truncated:
            break
    assert cut.min() < tracks["time_s"].max() - 1.0  # the cut track really ended mid-recording
    assert far > 0  # some recorded vehicles were out of the radius, and so out of SUMO


def test_vehicles_out_of_the_replay_radius_change_nothing_for_the_ego(drivers_scene, replay, monkeypatch):
    """The same seat and actions with every vehicle in SUMO (an unbounded radius) give the same observations."""
    tracks = replay.scene.tracks
    vehicle, start_s = long_track(tracks)
    actions = [Action.DECELERATE] * 4 + [Action.LANE_LEFT] + [Action.ACCELERATE] * 10
    runs = []
    for radius_m in (REPLAY_RADIUS_M, 1e9):
        monkeypatch.setattr(replayed_traffic, "REPLAY_RADIUS_M", radius_m)
        runs.append(observations(replay, vehicle, start_s, actions, seed=0))
    np.testing.assert_array_equal(runs[0], runs[1])


def observations(env: SceneEnv, vehicle: str, start_s: float, actions: list[Action], seed: int) -> np.ndarray:
    """The observations of one episode in `vehicle`'s seat under `actions` (until it ends)."""
    observation, _ = env.reset(seed=seed, options={"vehicle": vehicle, "start_s": start_s})
    rows = [observation]
    for action in actions:
        observation, _, terminated, truncated, _ = env.step(int(action))
        rows.append(observation)
        if terminated or truncated:
            break
    return np.array(rows)


def test_reactive_followers_brake_for_a_slowing_ego_and_replayed_ones_do_not(drivers_scene):
    """The same seat and actions in both modes: behind a braking ego, the reactive follower leaves its recorded track
    (it brakes), the replayed one stays on it (and may run into the ego)."""
    deviations, slowest, collided = {}, {}, {}
    for reactive in (False, True):
        env = SceneEnv(CONFIG, drivers_scene, reactive=reactive)
        try:
            tracks = env.scene.tracks
            vehicle, start_s = follower_seat(env, tracks)
            env.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
            follower = env_follower(env)
            api, time_s, deviation, below = env.simulation._api, start_s, 0.0, 0.0
            for _ in range(16):
                _, _, terminated, truncated, _ = env.step(int(Action.DECELERATE))
                time_s += CONFIG.env.decision_period_s
                if follower not in api.vehicle.getIDList() or terminated or truncated:
                    break
                x, _ = api.vehicle.getPosition(follower)
                deviation = max(deviation, abs(x - recorded(tracks, time_s).at[follower, "x_m"]))
                below = max(below, recorded(tracks, time_s).at[follower, "speed_mps"] - api.vehicle.getSpeed(follower))
            deviations[reactive], slowest[reactive], collided[reactive] = deviation, below, env.metrics.collisions
        finally:
            env.close()
    assert deviations[False] < 1e-3 and slowest[False] < 0.1  # the speed its recorded moves imply
    assert deviations[True] > 1.0 and slowest[True] > 2.0 and collided[True] == 0


def test_reactive_vehicles_are_handed_to_sumos_models_after_their_first_step(drivers_scene):
    """Placed at their recorded state, then SUMO's: its safety checks on speed (SUMO's default speed mode 31), its lane
    changing and a desired speed of the fastest speed their track records; replayed vehicles keep the checks and lane
    changing off."""
    for reactive in (False, True):
        env = SceneEnv(CONFIG, drivers_scene, reactive=reactive)
        try:
            tracks = env.scene.tracks
            vehicle, start_s = long_track(tracks)
            env.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
            env.step(int(Action.KEEP))
            api, top = env.simulation._api, tracks.groupby("vehicle_id")["speed_mps"].max()
            others = set(api.vehicle.getIDList()) - {EGO_ID}
            modes = {(api.vehicle.getSpeedMode(other), api.vehicle.getLaneChangeMode(other)) for other in others}
            assert modes == ({(31, 1621)} if reactive else {(0, 0)})
            if reactive:
                for other in others:
                    limit_mps = env.simulation.speed_limit_mps
                    assert api.vehicle.getSpeedFactor(other) * limit_mps == pytest.approx(top[other])
        finally:
            env.close()


def follower_seat(env: SceneEnv, tracks: pd.DataFrame) -> tuple[str, float]:
    """A car with a recorded follower within 40 m behind it in its lane at 2 s into its track."""
    spans = tracks.groupby("vehicle_id").agg(begin=("time_s", "min"), end=("time_s", "max"),
                                             kind=("vehicle_class", "first"))
    for vehicle, row in spans[(spans["end"] - spans["begin"] >= 15) & (spans["kind"] == "passenger")].iterrows():
        start_s = float(row["begin"] + 2.0)
        frame = recorded(tracks, start_s)
        me = frame.loc[vehicle]
        behind = frame[(frame["lane"] == me["lane"]) & (frame["lane_position_m"] < me["lane_position_m"])
                       & (frame["lane_position_m"] > me["lane_position_m"] - 40.0)]
        if len(behind):
            return str(vehicle), start_s
    raise AssertionError("no car with a close follower in the scene")


def env_follower(env: SceneEnv) -> str:
    traffic = env.traffic
    same = [(position, name) for name, position, lane in zip(traffic.neighbours.ids,
                                                             traffic.neighbours.lane_position_m,
                                                             traffic.neighbours.lane, strict=True)
            if lane == traffic.ego.lane and position < traffic.ego.lane_position_m]
    return max(same)[1]


def test_sumo_drives_the_seat_when_asked(replay):
    tracks = replay.scene.tracks
    vehicle, start_s = long_track(tracks)
    replay.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s, "controller": "sumo"})
    api = replay.simulation._api
    assert api.vehicle.getTypeID(EGO_ID).split("@")[0] == SUMO_DRIVER_TYPE  # "@ego": its own copy, of the seat's size
    assert api.vehicle.getLength(EGO_ID) == pytest.approx(recorded(tracks, start_s).at[vehicle, "length_m"])
    start = replay.traffic.ego.lane_position_m
    for _ in range(4):
        _, _, terminated, _, info = replay.step(int(Action.LANE_LEFT))  # ignored: SUMO drives
        assert not terminated
    assert replay.metrics.decisions == 4
    assert replay.metrics.invalid_actions == 0 and info["position_m"] > start + 20.0


def test_a_sumo_driven_seat_ignores_the_actions(replay):
    """With SUMO's controller the episode is SUMO's whatever the actions: braking or accelerating, the same states;
    the controller named for the ego alone is the same."""
    vehicle, start_s = long_track(replay.scene.tracks)
    runs = []
    for action, controller in ((Action.DECELERATE, "sumo"), (Action.ACCELERATE, {EGO_ID: "sumo"})):
        replay.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s, "controller": controller})
        runs.append([replay.step(int(action))[0] for _ in range(4)])
    np.testing.assert_array_equal(runs[0], runs[1])
    replay.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s, "controller": "actions"})
    assert replay.simulation._api.vehicle.getTypeID(EGO_ID).split("@")[0] != SUMO_DRIVER_TYPE


def test_the_seat_is_taken_where_the_track_begins_by_default(replay):
    """By default the ego takes the seat where the vehicle's track begins, or one SUMO step into the scene for a
    vehicle on the road from its first instant (SUMO's run begins a step before the seat); before that is an error."""
    tracks = replay.scene.tracks
    step_s = replay.config.scenario.step_length_s
    begins = tracks.groupby("vehicle_id")["time_s"].min()
    late = begins[begins > begins.min() + 1.0].index[0]
    replay.reset(seed=0, options={"vehicle": late})
    first = replay.scene.track(late).iloc[0]
    assert replay.simulation.time_s == pytest.approx(first["time_s"])
    assert replay.traffic.ego.lane_position_m == pytest.approx(first["lane_position_m"], abs=1e-6)
    vehicle, _ = long_track(tracks)
    if begins[vehicle] < step_s:
        replay.reset(seed=0, options={"vehicle": vehicle})
        assert replay.simulation.time_s == pytest.approx(step_s) and replay.traffic.ego.lane == recorded(
            tracks, 0.0).at[vehicle, "lane"]
        with pytest.raises(ValueError, match="'start_s' must be a time at least one SUMO step"):
            replay.reset(seed=0, options={"vehicle": vehicle, "start_s": 0.0})


def test_a_seat_off_sumos_step_grid_begins_sumo_on_it_and_one_on_it_as_before(replay, monkeypatch):
    """A seat at 12.34 s (a highD frame, 25 Hz) began SUMO at 12.24 s, off its 0.1 s step grid ("Warning: The given
    time value 12.24 is not a multiple of the step length 0.10 for begin." where SUMO's warnings are shown); now SUMO
    begins at 12.2 s and the replay and the ego's clock keep the scene's time. On the grid, SUMO is loaded as before
    (the same --begin, no offset), so those episodes are the same bit for bit."""
    tracks = replay.scene.tracks
    vehicle, start_s = long_track(tracks)
    replay.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
    loads: list[list[str]] = []
    load = replay.simulation._load
    monkeypatch.setattr(replay.simulation, "_load", lambda options: (loads.append(options), load(options)))
    replay.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
    assert loads[-1][:2] == ["--begin", repr(start_s - 0.1)] and replay.simulation.clock_offset_s == 0.0
    off_s = start_s + 0.04
    replay.reset(seed=0, options={"vehicle": vehicle, "start_s": off_s})
    assert round(float(loads[-1][1]) * 1000) % 100 == 0  # SUMO's test: whole milliseconds, a multiple of the step
    assert float(loads[-1][1]) == pytest.approx(off_s - 0.14)
    assert replay.simulation.time_s == pytest.approx(off_s)
    track = replay.scene.track(vehicle)
    human_m = np.interp(off_s, track["time_s"], track["lane_position_m"])
    assert replay.traffic.ego.lane_position_m == pytest.approx(human_m, abs=1e-6)
    replay.step(int(Action.KEEP))  # the others where the recording has them half a second later, in scene time
    later, api = replay.simulation.time_s, replay.simulation._api
    assert later == pytest.approx(off_s + CONFIG.env.decision_period_s)
    others = set(api.vehicle.getIDList()) - {EGO_ID}
    assert others
    for other in others:
        track = replay.scene.track(other)
        x, y = api.vehicle.getPosition(other)
        assert np.hypot(x - np.interp(later, track["time_s"], track["x_m"]),
                        y - np.interp(later, track["time_s"], track["y_m"])) < 1e-3


def test_libsumo_and_traci_drive_the_same_seat_alike(drivers_scene, replay):
    """The fixture's env holds libsumo; the same seat over traci gives the same states, decision by decision."""
    tracks = replay.scene.tracks
    vehicle, start_s = long_track(tracks)
    actions = [Action.ACCELERATE, Action.LANE_LEFT, Action.KEEP, Action.DECELERATE, Action.LANE_RIGHT] * 3
    states = []
    for env in (replay, SceneEnv(CONFIG, drivers_scene, reactive=False, transport="traci")):
        states.append(observations(env, vehicle, start_s, actions, seed=3))
        if env is not replay:
            env.close()
    np.testing.assert_array_equal(states[0], states[1])


def test_a_seats_lead_in_is_the_pandas_tracks_rows_before_the_seat(drivers_scene):
    """The lead-in a reset reads off arrays (`Scene.track_values`, `SeatStart.past`) is the one read off the
    vehicle's DataFrame (`Scene.track`) before the seat's instant, bit for bit: every vehicle, at several instants, in a
    scene whose rows are neither contiguous nor in time order too."""
    scene = read_scene(drivers_scene)
    shuffled = dataclasses.replace(scene, tracks=scene.tracks.sample(frac=1.0, random_state=0, ignore_index=True))
    for each in (scene, shuffled):
        start = SeatStart(each, SceneFrames(each.tracks, each.meta.frame_rate_hz), scene_road(each.network), False,
                          SeatDraw(each, "train", 10.0, 5.0, 0.0, 0.1))
        for vehicle in each.tracks["vehicle_id"].unique()[::3]:
            track = each.track(vehicle)
            values = each.track_values(vehicle, TRACK_COLUMNS)
            for name in TRACK_COLUMNS:
                np.testing.assert_array_equal(values[name], track[name].to_numpy(), strict=True)
            for start_s in np.quantile(track["time_s"], [0.0, 0.3, 1.0]):
                replay = SimpleNamespace(traffic=SimpleNamespace(seated=(vehicle, float(start_s))))
                with patch("sumo_rail.recordings.seat.replayed", lambda sim: sim.traffic):
                    past = start.past(replay, EGO_ID)  # type: ignore[arg-type]
                old = track_past(track[track["time_s"] < start_s - 1e-9])
                assert (past.time_s, past.speed_mps, past.acceleration_mps2, past.lane) == (
                    old.time_s, old.speed_mps, old.acceleration_mps2, old.lane)
    with pytest.raises(DatasetError, match="no vehicle 'nobody'"):
        scene.track_values("nobody", TRACK_COLUMNS)


def _step_by_wrappers(self):
    """`ReplayedTraffic.step` as it was before it called libsumo's compiled functions (issue 52): an oracle below."""
    api = self.api
    end_s = api.simulation.getTime() + self._step_s
    self._place(end_s, api.vehicle.getPosition(EGO_ID)[0] if self._ego_in and not self.reactive else None)
    api.simulationStep(end_s)
    simulation = api.simulation
    if simulation.getCollidingVehiclesNumber():
        self.ego_collisions += [(collision.collider, collision.victim) for collision in simulation.getCollisions()
                                if EGO_ID in (collision.collider, collision.victim)]
        self._ego_in = self._ego_in and not self.ego_collisions
    if self._ego_in and simulation.getArrivedNumber() and EGO_ID in simulation.getArrivedIDList():
        self._ego_in = False


def _release_by_wrappers(self):
    """`ReplayedTraffic._release` as it was before it called libsumo's compiled functions: an oracle below."""
    vehicle = self.api.vehicle
    on_road = set(vehicle.getIDList()) if self._releasing else set()
    for name in self._releasing:
        if name in on_road:
            vehicle.setSpeedMode(name, replayed_traffic.SPEED_MODE_SUMO)
            vehicle.setLaneChangeMode(name, LANE_CHANGE_MODE_SUMO)
            vehicle.setSpeedFactor(name, self._speed_factor[name])
    self._releasing.clear()


def _place_vehicle_by_vehicle(self, time_s, ego_x_m):
    """`ReplayedTraffic._place` as it was before its moves were looped in C and its calls were libsumo's compiled
    functions (issue 52): an oracle of the test below."""
    if self.reactive:
        self._release()
        begun = np.searchsorted(self._begins_s, [self._last_s, time_s], side="right")
        first, self._last_s = not self._placed, time_s
        if not first and begun[0] == begun[1]:
            return
    ids, values, lanes = self.frames_at(time_s)
    x = values["x_m"]
    placed_columns = ("x_m", "y_m", "heading_deg", "speed_mps", "length_m", "width_m", "edge")
    if not self.reactive:
        if ego_x_m is None:
            seat = np.flatnonzero(ids == self._skip)
            ego_x_m = float(x[seat[0]]) if len(seat) else None
        if ego_x_m is not None:
            near = np.flatnonzero(np.abs(x - ego_x_m) <= replayed_traffic.REPLAY_RADIUS_M)
            ids, lanes, values = ids[near], lanes[near], {name: values[name][near] for name in placed_columns}
    names = ids.tolist()
    vehicle = self.api.vehicle
    on_road = set(vehicle.getIDList())
    if not self.reactive:
        for gone in self._placed.difference(names):
            if gone in on_road:
                vehicle.remove(gone)
        self._placed.intersection_update(names)
    type_of = self.types.of_vehicle if self.reactive else {}
    rows = zip(names, lanes.tolist(), *(values[name].tolist() for name in placed_columns), strict=True)
    for name, lane, x_m, y_m, heading_deg, speed_mps, length_m, width_m, edge in rows:
        if name == self._skip or (self.reactive and name in self._placed):
            continue
        if name not in on_road:
            route_id, depart_lane = self._entry(name, edge, lane)
            vehicle.add(name, route_id, type_of.get(name, replayed_traffic.DEFAULT_TYPE), departLane=depart_lane,
                        departSpeed=repr(speed_mps))
            vehicle.setLength(name, length_m)
            vehicle.setWidth(name, width_m)
            vehicle.setSpeedMode(name, 0)
            vehicle.setLaneChangeMode(name, 0)
            self._placed.add(name)
            if self.reactive:
                self._releasing.append(name)
        elif self.reactive:
            continue
        vehicle.moveToXY(name, edge, lane, x_m, y_m, heading_deg, replayed_traffic.KEEP_ROUTE_ANY_EDGE)


class _EveryVehicle:
    """Every vehicle's state after every SUMO step, read by plain getters (`VehicleRows`' subscriptions are not left
    to SUMO's state changes here: a vehicle the replay removes before a step would be reported unknown in it)."""

    every_step = True

    def __init__(self, api) -> None:
        self.api, self.steps = api, []

    def __call__(self, moment) -> None:
        v = self.api.vehicle
        self.steps.append((moment.time_s, [(name, v.getPosition(name), v.getAngle(name), v.getSpeed(name),
                                            v.getAcceleration(name), v.getLaneID(name), v.getLanePosition(name),
                                            v.getLateralLanePosition(name)) for name in v.getIDList()]))


@pytest.mark.parametrize("reactive", [False, True])
def test_seat_episodes_are_those_of_the_vehicle_by_vehicle_placement(drivers_scene, reactive, monkeypatch):
    """The replay that moves its vehicles in one C loop and calls libsumo's compiled functions drives the same
    episodes as the one that placed them vehicle by vehicle through libsumo's Python wrappers: every vehicle's state
    after every SUMO step and the ego's every info, in seats where vehicles enter and leave the replay radius (a
    radius of 150 m) and the ego changes lanes."""
    monkeypatch.setattr(replayed_traffic, "REPLAY_RADIUS_M", 150.0)
    seats = [long_track(read_scene(drivers_scene).tracks, lane) for lane in (0, 1)]
    actions = [Action.LANE_LEFT, Action.KEEP, Action.ACCELERATE, Action.LANE_RIGHT, Action.KEEP, Action.DECELERATE] * 4
    episodes = []
    traffic = replayed_traffic.ReplayedTraffic
    for replay in ((traffic.step, traffic._place, traffic._release),
                   (_step_by_wrappers, _place_vehicle_by_vehicle, _release_by_wrappers)):
        for method, function in zip(("step", "_place", "_release"), replay, strict=True):
            monkeypatch.setattr(traffic, method, function)
        env = SceneEnv(CONFIG, drivers_scene, reactive=reactive)  # its simulation takes the step as it starts
        try:
            env.reset(seed=0, options={"vehicle": seats[0][0], "start_s": seats[0][1]})
            with env.simulation.watching(_EveryVehicle(env.simulation._api)) as watched:
                infos = []
                for vehicle, start_s in seats:
                    infos.append(env.reset(seed=3, options={"vehicle": vehicle, "start_s": start_s})[1])
                    for action in actions:
                        _, _, terminated, truncated, info = env.step(int(action))
                        infos.append(info)
                        if terminated or truncated:
                            break
            episodes.append((watched.steps, infos))
        finally:
            env.close()
    assert sum(len(vehicles) for _, vehicles in episodes[0][0]) > 1000
    assert episodes[0] == episodes[1]
