"""The multi-ego PettingZoo environment: its API, the single ego's episodes with K = 1, determinism, egos leaving,
the start rule and egos seeing each other."""

from __future__ import annotations

import dataclasses

import gymnasium
import libsumo
import numpy as np
import pytest
from pettingzoo.test import parallel_api_test, parallel_seed_test

import sumo_rail
from sumo_rail.sim import parallel_env, simulation, starts
from sumo_rail.sim.actions import Action
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.parallel_env import ParallelHighwayEnv
from sumo_rail.sim.simulation import SimulationError
from sumo_rail.sim.starts import GAP_M, MIN_SLOT_M, EpisodeStarts, check_start_slots, start_slots
from sumo_rail.sim.traffic import TrafficView
from sumo_rail.sim.vehicles import Neighbours


@pytest.fixture
def make_env(small_config):
    """`make_env(K)`: a K-ego env on the small scenario, closed after the test."""
    made: list[ParallelHighwayEnv] = []

    def make(egos: int) -> ParallelHighwayEnv:
        made.append(sumo_rail.parallel_env(egos=egos, config=small_config))
        return made[-1]
    yield make
    for env in made:
        env.close()


def drive(env: ParallelHighwayEnv, seed: int):
    """One episode with seeded random actions: per decision (agents, observations, rewards, terminations,
    truncations, infos, traffic views before the step); the reset's observations and infos first."""
    rng = np.random.default_rng(seed)
    observations, infos = env.reset(seed=seed)
    decisions = [(list(env.agents), observations, {}, {}, {}, infos, {})]
    while env.agents:
        views = {agent: env.traffic(agent) for agent in env.agents}
        actions = {agent: int(rng.integers(len(Action))) for agent in env.agents}
        agents = list(env.agents)
        decisions.append((agents, *env.step(actions), views))
    return decisions


def same_view(a: TrafficView, b: TrafficView) -> bool:
    return a.ego == b.ego and a.set_point_mps == b.set_point_mps and a.neighbours.ids == b.neighbours.ids and all(
        np.array_equal(getattr(a.neighbours, f.name), getattr(b.neighbours, f.name))
        for f in dataclasses.fields(Neighbours)[1:])


def test_pettingzoo_parallel_api_test_passes(make_env):
    env = make_env(3)
    with pytest.warns(UserWarning, match="ignored unknown reset options"):  # the API test passes {"options": 1}
        parallel_api_test(env, num_cycles=1000)
    assert env.possible_agents == ["ego_0", "ego_1", "ego_2"]
    assert env.observation_space("ego_1") == HighwayEnv(env.config).observation_space
    assert env.action_space("ego_2") == gymnasium.spaces.Discrete(5)


def test_pettingzoo_parallel_seed_test_passes_with_two_envs_in_one_process(small_config):
    assert sumo_rail.parallel_env(egos=2, config=small_config).render_mode is None
    with pytest.warns(UserWarning, match="runs over traci"):  # the second env: libsumo is the first one's
        parallel_seed_test(lambda: sumo_rail.parallel_env(egos=3, config=small_config), num_cycles=40)


@pytest.mark.parametrize(("seed", "options"), [(9, None), (4, {"pool": "validation", "warm_state": 1})])
def test_one_ego_drives_highway_envs_episode_bit_for_bit(small_config, seed, options):
    rng = np.random.default_rng(seed)
    actions = rng.integers(len(Action), size=400).tolist()
    single = HighwayEnv(small_config)
    try:
        observation, info = single.reset(seed=seed, options=options)
        expected = [(observation, 0.0, False, False, info, None)]
        for action in actions:
            view = single.traffic
            observation, reward, terminated, truncated, info = single.step(action)
            expected.append((observation, reward, terminated, truncated, info, view))
            if terminated or truncated:
                break
        expected_metrics = dataclasses.asdict(single.metrics)
    finally:
        single.close()
    env = sumo_rail.parallel_env(egos=1, config=small_config)
    try:
        observations, infos = env.reset(seed=seed, options=options)
        actual = [(observations["ego_0"], 0.0, False, False, infos["ego_0"], None)]
        for action in actions[:len(expected) - 1]:
            view = env.traffic("ego_0")
            observations, rewards, terminations, truncations, infos = env.step({"ego_0": action})
            actual.append((observations["ego_0"], rewards["ego_0"], terminations["ego_0"], truncations["ego_0"],
                           infos["ego_0"], view))
        assert env.agents == [] and dataclasses.asdict(env.metrics("ego_0")) == expected_metrics
    finally:
        env.close()
    assert len(actual) == len(expected) > 40
    for (*want, want_view), (*got, got_view) in zip(expected, actual, strict=True):
        assert np.array_equal(got[0], want[0]) and got[0].dtype == want[0].dtype
        assert got[1:] == want[1:]
        assert want_view is None or same_view(got_view, want_view)


def test_same_seed_same_trajectories_and_another_seed_differs(make_env):
    env = make_env(4)
    first, other, again = drive(env, 5), drive(env, 6), drive(env, 5)
    assert len(first) == len(again)
    for a, b in zip(first, again, strict=True):
        assert a[0] == b[0] and a[2:6] == b[2:6]  # agents, rewards, terminations, truncations, infos
        assert all(np.array_equal(a[1][agent], b[1][agent]) for agent in a[1])
        assert all(same_view(a[6][agent], b[6][agent]) for agent in a[6])
    assert not np.array_equal(first[0][1]["ego_0"], other[0][1]["ego_0"])


def test_egos_that_finish_or_collide_leave_agents_while_the_others_drive_on(make_env):
    env = make_env(4)
    _, infos = env.reset(seed=2)
    # ego_3, farthest down the road, is driven into a truck stopped ahead of it
    libsumo.vehicle.setSpeedMode("ego_3", 0)
    libsumo.vehicle.setSpeed("ego_3", 55.0)
    libsumo.vehicle.add("blocker", "highway_route", typeID="truck", depart="now",
                        departLane=str(infos["ego_3"]["lane"]), departPos=str(infos["ego_3"]["position_m"] + 60.0),
                        departSpeed="0")
    left_at: dict[str, int] = {}
    endings: dict[str, tuple] = {}
    decision = 0
    while env.agents:
        decision += 1
        driving = list(env.agents)
        _, rewards, terminations, truncations, infos = env.step(dict.fromkeys(driving, Action.KEEP))
        assert set(rewards) == set(driving)
        for agent in driving:
            if terminations[agent] or truncations[agent]:
                left_at[agent] = decision
                endings[agent] = (terminations[agent], rewards[agent], infos[agent]["termination"])
                assert agent not in env.agents
        if "ego_3" in left_at and decision == left_at["ego_3"]:
            assert env.agents and set(env.agents) <= {"ego_0", "ego_1", "ego_2"}
            with pytest.raises(ValueError, match="not driving \\['ego_3'\\]"):
                env.step({agent: Action.KEEP for agent in [*env.agents, "ego_3"]})
    assert endings["ego_3"] == (True, -10.0, "collision") and env.metrics("ego_3").collisions == 1
    assert all(endings[agent][::2] == (False, "end_of_road") for agent in ("ego_0", "ego_1", "ego_2"))
    assert left_at["ego_3"] < max(left_at.values())  # the others drove on after the collision
    assert all(env.metrics(agent).decisions == left_at[agent] for agent in left_at)
    with pytest.raises(RuntimeError, match="every ego has left"):
        env.step({})


def test_start_slots_share_the_single_egos_window_and_widen_when_it_is_too_narrow(small_config):
    assert start_slots(small_config, 1) == [(300.0, 500.0)]  # HighwayEnv's window
    assert start_slots(small_config, 4) == [(300.0, 350.0 - GAP_M), (350.0, 400.0 - GAP_M),
                                            (400.0, 450.0 - GAP_M), (450.0, 500.0)]
    wide = start_slots(small_config, 16)  # 200 m / 16 < 40 m: slots of 40 m past the window
    assert wide[0] == (300.0, 340.0 - GAP_M) and wide[-1] == (300.0 + 15 * MIN_SLOT_M, 300.0 + 16 * MIN_SLOT_M)
    with pytest.raises(ValueError, match="30 egos need start slots"):
        check_start_slots(small_config, 30, small_config.scenario.length_m)
    check_start_slots(small_config, 30, 2000.0)  # a user's route of 2 km holds them
    for egos in (0, 2.5, True):
        with pytest.raises(ValueError, match="egos must be an integer"):
            start_slots(small_config, egos)


def test_two_egos_whose_slots_pass_the_roads_end_margin_are_refused_at_once(small_config):
    """One ego always fits its start window; two that need slots past the end margin are a ValueError before SUMO
    starts."""
    near_the_end = small_config.with_overrides({"env": {"ego_start_min_m": 1350.0, "ego_start_max_m": 1390.0}})
    assert ParallelHighwayEnv(1, near_the_end).slots == [(1350.0, 1390.0)]
    with pytest.raises(ValueError, match="2 egos need start slots of 40 m from 1350 m to 1430 m"):
        ParallelHighwayEnv(2, near_the_end)


def test_egos_enter_where_the_rule_draws_them(make_env, small_config):
    env = make_env(4)
    for seed in (0, 1):
        _, infos = env.reset(seed=seed)
        rng, _ = gymnasium.utils.seeding.np_random(seed)
        starts = EpisodeStarts.draw(rng, small_config, small_config.scenario.snapshots, egos=4)
        for k, agent in enumerate(env.agents):
            low, high = env.slots[k]
            assert low <= starts.positions_m[k] <= high
            assert infos[agent]["lane"] == starts.lanes[k]  # egos make no lane change by themselves
            departed_at_m = infos[agent]["position_m"] - libsumo.vehicle.getDistance(agent)
            assert departed_at_m == pytest.approx(starts.positions_m[k], abs=0.01)
        assert np.all(np.diff(starts.positions_m) >= GAP_M)


def test_an_ego_that_finds_no_room_sits_the_episode_out(make_env, monkeypatch):
    env = make_env(2)

    class BothAtOnePlace:  # ego_1 is drawn where ego_0 stands, and waits one step at most
        @staticmethod
        def draw(rng, config, snapshots, egos, start_lanes):
            return EpisodeStarts(0, 1, (1, 1), (400.0, 400.0))
    monkeypatch.setattr(simulation, "ENTRY_WAIT_S", 0.1)
    monkeypatch.setattr(starts, "EpisodeStarts", BothAtOnePlace)
    observations, infos = env.reset(seed=0)
    assert env.agents == ["ego_0"] and set(observations) == set(infos) == {"ego_0"}
    assert "ego_1" not in libsumo.vehicle.getIDList() + libsumo.simulation.getPendingVehicles()
    with pytest.raises(RuntimeError, match="ego_1 could not enter the road"):
        env.traffic("ego_1")
    _, rewards, *_ = env.step({"ego_0": Action.KEEP})
    assert set(rewards) == {"ego_0"} and env.metrics("ego_1").decisions == 0


def test_an_ego_that_finds_no_room_has_no_episode_of_a_rollout_but_respawns_within_a_budget(make_env, monkeypatch):
    """`drive_egos` without a budget: whole episodes, none for the ego that sat out (it is not respawned); with a
    budget, it respawns at once and drives its decisions."""
    from sumo_rail.runners.rollout import drive_egos, run_shared_episode

    class BothAtOnePlace:
        @staticmethod
        def draw(rng, config, snapshots, egos, start_lanes):
            return EpisodeStarts(0, 1, (1, 1), (400.0, 400.0))
    monkeypatch.setattr(simulation, "ENTRY_WAIT_S", 0.1)
    monkeypatch.setattr(starts, "EpisodeStarts", BothAtOnePlace)
    env = make_env(2)
    keep = [lambda observation, traffic: int(Action.KEEP)] * 2
    first, second = run_shared_episode(env, keep, 0)
    assert second is None and first is not None and first.metrics["steps"] > 10
    lives = drive_egos(env, keep, 0, 5)
    assert [sum(life.metrics["steps"] for life in ego_lives) for ego_lives in lives] == [5, 5]


class Decisions:
    """An observer of decisions keeping each ego's: what it decided on (its observation, its position [m]) and did."""

    every_step = False

    def __init__(self) -> None:
        self.seen: dict[str, list] = {}

    def __call__(self, moment) -> None:
        for decision in moment.decisions():
            self.seen.setdefault(decision.agent, []).append(
                (decision.observation, decision.traffic.ego.lane_position_m, decision.action))


def test_a_decision_observer_sees_what_each_ego_decided_on_and_did(make_env):
    """An observer of the env's decisions (`Moment.decisions`) sees exactly what ego_j's driver saw and did, decision
    by decision."""
    from sumo_rail.runners.rollout import drive_egos

    env = make_env(2)
    seen: list[list] = [[], []]

    def driver(j: int):
        def act(observation, traffic):
            seen[j].append((observation, traffic.ego.lane_position_m, j + 1, traffic.set_point_mps))
            return j + 1  # ego_0 accelerates, ego_1 decelerates
        return act

    with env.watching(Decisions()) as observer:
        lives = drive_egos(env, [driver(0), driver(1)], 3, 6)
    watched = [observer.seen["ego_0"], observer.seen["ego_1"]]
    # and each ego's car executes its own driver's actions
    assert lives[0][0].metrics["action_accelerate"] == lives[1][0].metrics["action_decelerate"] == 6
    assert env.traffic("ego_0").set_point_mps >= seen[0][0][3] and env.traffic("ego_1").set_point_mps < seen[1][0][3]
    for j in (0, 1):
        assert len(watched[j]) == len(seen[j]) == 6
        for (observation, position_m, action), (want_observation, want_m, want_action, _) in zip(
                watched[j], seen[j], strict=True):
            assert np.array_equal(observation, want_observation) and (position_m, action) == (want_m, want_action)


def test_render_draws_the_first_ego_on_the_road_when_ego_0_sat_out(small_config):
    """A video of the core must not break when ego_0 found no room: render() is then the first entered ego's frame,
    and ego_0's frame is a clear error."""

    @dataclasses.dataclass(frozen=True)
    class SecondOnly(starts.WarmStateStart):  # ego_0 sits the episode out
        def enter(self, sim, rng, config, agents, options):
            super().enter(sim, rng, config, agents[1:], options)
            return [agents[0]]

    env = ParallelHighwayEnv(2, small_config, render_mode="rgb_array", start=SecondOnly())
    try:
        env.reset(seed=0)
        assert env.agents == ["ego_1"]
        env.step({"ego_1": Action.KEEP})
        assert np.array_equal(env.render(), env.frame("ego_1"))
        with pytest.raises(RuntimeError, match="ego_0 could not enter the road"):
            env.frame("ego_0")
    finally:
        env.close()


def test_each_ego_sees_the_others_as_traffic(make_env):
    env = make_env(4)  # slots 50 m apart, within the 120 m context radius of each other
    observations, _ = env.reset(seed=0)
    assert "ego_1" in env.traffic("ego_0").neighbours.ids and "ego_0" in env.traffic("ego_1").neighbours.ids
    hits = 0
    for _ in range(30):
        for agent in env.agents:
            view = env.traffic(agent)
            kept = np.array([vehicle not in env.possible_agents for vehicle in view.neighbours.ids])
            others_gone = Neighbours(*(np.asarray(getattr(view.neighbours, f.name))[kept]
                                       for f in dataclasses.fields(Neighbours)))
            without = env._egos[agent].observation(view.ego, others_gone, view.ego.changing_lane, env.simulation.time_s)
            hits += not np.array_equal(without, observations[agent])  # its LIDAR hits another ego
        observations, *_ = env.step(dict.fromkeys(env.agents, Action.KEEP))
    assert hits > 0, hits


def test_bad_use_is_a_clear_error(make_env, small_config):
    env = make_env(2)
    with pytest.raises(RuntimeError, match="reset"):
        env.step({"ego_0": 0, "ego_1": 0})
    with pytest.raises(RuntimeError, match="reset"):
        env.traffic("ego_0")
    with pytest.raises(KeyError, match="no agent 'ego_7'"):
        env.metrics("ego_7")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="missing \\['ego_1'\\]"):
        env.step({"ego_0": 0})
    with pytest.raises(ValueError, match="action must be"):
        env.step({"ego_0": 0, "ego_1": 5})
    with pytest.raises(ValueError, match="warm_state"):
        env.reset(seed=0, options={"warm_state": 99})
    with pytest.raises(ValueError, match="transport"):
        ParallelHighwayEnv(2, small_config, transport="socket")
    with pytest.raises(SimulationError, match="one simulation per process"):
        HighwayEnv(small_config, transport="libsumo").reset(seed=0)


def test_close_ends_the_episode_and_a_reset_after_it_starts_a_new_simulation(make_env):
    env = make_env(2)
    env.reset(seed=0)
    env.close()
    assert env.agents == [] and env.simulation is None
    with pytest.raises(RuntimeError, match="reset"):
        env.step({"ego_0": 0, "ego_1": 0})
    observations, _ = env.reset(seed=0)
    assert set(observations) == {"ego_0", "ego_1"} and env.simulation is not None
    _, rewards, *_ = env.step(dict.fromkeys(env.agents, Action.KEEP))
    assert set(rewards) == {"ego_0", "ego_1"}


def test_an_ended_ego_respawns_at_once_in_the_start_window_while_the_others_drive_on(make_env, small_config):
    env = make_env(3)
    with pytest.raises(RuntimeError, match="reset"):
        env.respawn("ego_0")
    env.reset(seed=1)
    with pytest.raises(ValueError, match="ego_0 is driving"):
        env.respawn("ego_0")
    ended: list[str] = []
    while not ended:
        _, _, terminations, truncations, _ = env.step(dict.fromkeys(env.agents, Action.ACCELERATE))
        ended = [agent for agent in terminations if terminations[agent] or truncations[agent]]
    others = list(env.agents)
    observation, info = env.respawn(ended[0])
    assert env.agents == [agent for agent in env.possible_agents if agent in [*others, ended[0]]]
    assert f"{ended[0]}.1" in libsumo.vehicle.getIDList() and env.metrics(ended[0]).decisions == 0
    assert env.observation_space(ended[0]).contains(observation)
    assert small_config.env.ego_start_min_m <= info["position_m"] <= small_config.env.ego_start_max_m
    assert info["distance_m"] == 0.0 and info["termination"] == ""
    assert env.traffic(ended[0]).ego.lane_position_m == info["position_m"]
    _, rewards, *_ = env.step(dict.fromkeys(env.agents, Action.KEEP))
    assert set(rewards) == set(env.agents) | {ended[0]} and env.metrics(ended[0]).decisions == 1


def test_respawned_egos_keep_the_agents_order(small_config):
    """`agents` stays in `possible_agents`' order whatever the order of the respawns (drivers are asked, and the
    outcomes given, in ego order)."""
    env = ParallelHighwayEnv(3, small_config.with_overrides({"env": {"max_episode_s": 2.0}}))
    try:
        env.reset(seed=0)
        while env.agents:  # the time limit ends every ego's episode at once
            env.step(dict.fromkeys(env.agents, Action.KEEP))
        for agent in ("ego_2", "ego_0"):
            env.respawn(agent)
        assert env.agents == ["ego_0", "ego_2"]
        observations, rewards, *_ = env.step(dict.fromkeys(env.agents, Action.KEEP))
        assert list(observations) == list(rewards) == ["ego_0", "ego_2"]
    finally:
        env.close()


def test_a_jammed_start_window_sends_a_respawn_upstream_and_a_full_road_is_an_error(make_env, small_config,
                                                                                      monkeypatch):
    env = make_env(2)
    env.reset(seed=2)
    while len(env.agents) == 2:
        env.step(dict.fromkeys(env.agents, Action.ACCELERATE))
    ended = next(agent for agent in env.possible_agents if agent not in env.agents)
    place = env.simulation.place_ego
    window_m = (small_config.env.ego_start_min_m, small_config.env.ego_start_max_m)
    tried: list[float] = []

    def jammed_window(vehicle, lane, position_m, max_speed_mps):  # no room in the start window
        tried.append(position_m)
        return not window_m[0] <= position_m <= window_m[1] and place(vehicle, lane, position_m, max_speed_mps)

    monkeypatch.setattr(env.simulation, "place_ego", jammed_window)
    _, info = env.respawn(ended)
    assert env.simulation.ego_length_m <= info["position_m"] < window_m[0] and ended in env.agents
    assert all(window_m[0] <= position_m <= window_m[1] for position_m in tried[:parallel_env.RESPAWN_DRAWS])
    monkeypatch.setattr(env.simulation, "place_ego", lambda *place_args: False)
    while len(env.agents) == 2:
        env.step(dict.fromkeys(env.agents, Action.ACCELERATE))
    ended = next(agent for agent in env.possible_agents if agent not in env.agents)
    env.np_random = windows = DrawnWindows(env.np_random)
    with pytest.raises(SimulationError, match=rf"no safe place for {ended} to respawn in 200 draws up to 500 m: "
                                              r"traffic is too dense there \(scenario\.flow_veh_per_h is 4000"):
        env.respawn(ended)
    # the start window, then from one ego length in (its rear on the road) to the window's end
    upstream_m = (env.simulation.ego_length_m, window_m[1])
    assert windows.bounds == [window_m] * parallel_env.RESPAWN_DRAWS + [upstream_m] * parallel_env.RESPAWN_DRAWS


class DrawnWindows:
    """A generator that draws as `generator` does and keeps the bounds of every uniform draw."""

    def __init__(self, generator: np.random.Generator) -> None:
        self.generator = generator
        self.bounds: list[tuple[float, float]] = []

    def integers(self, *args, **kwargs):
        return self.generator.integers(*args, **kwargs)

    def uniform(self, low: float, high: float) -> float:
        self.bounds.append((low, high))
        return self.generator.uniform(low, high)


def test_a_respawn_is_placed_only_where_it_is_safe(make_env):
    env = make_env(1)
    env.reset(seed=3)
    sim = env.simulation
    lane = 2
    vehicles = sorted(libsumo.lane.getLastStepVehicleIDs(f"highway_{lane}"), key=libsumo.vehicle.getLanePosition)
    occupied_m = libsumo.vehicle.getLanePosition(vehicles[len(vehicles) // 2])
    assert not sim.place_ego("on_top", lane, occupied_m, 33.33)
    assert not sim.place_ego("tailgated", lane, occupied_m + 4.5 + 1.0, 33.33)  # that vehicle 1 m behind its rear
    rear_m = occupied_m - libsumo.vehicle.getLength(vehicles[len(vehicles) // 2])
    libsumo.vehicle.setSpeed(vehicles[len(vehicles) // 2], 40.0)  # however fast the leader, not at its bumper
    assert not sim.place_ego("tailgating", lane, rear_m - 1.0, 33.33)
    assert not {"on_top", "tailgated", "tailgating"} & set(libsumo.vehicle.getIDList()
                                                           + libsumo.simulation.getPendingVehicles())
    start_s = libsumo.simulation.getTime()
    placed = [position_m for position_m in np.arange(100.0, 1400.0, 10.0)
              if sim.place_ego(f"placed_{position_m:.0f}", lane, float(position_m), 33.33)]
    assert placed  # safe places exist on a light road, and each is at least a secure gap from the next
    for position_m in placed:
        vehicle = f"placed_{position_m:.0f}"
        assert libsumo.vehicle.getLanePosition(vehicle) == position_m and libsumo.vehicle.getSpeed(vehicle) <= 33.33
    collisions, lowest_mps2 = set(), 0.0
    for _ in range(300):  # 30 s: nobody crashes into a placed vehicle, nor it into anybody
        libsumo.simulationStep()
        collisions |= set(libsumo.simulation.getCollidingVehiclesIDList())
        lowest_mps2 = min([lowest_mps2, *(libsumo.vehicle.getAcceleration(f"placed_{position_m:.0f}")
                                          for position_m in placed if libsumo.simulation.getTime() < 2.0 + start_s)])
    assert not collisions, collisions
    assert lowest_mps2 > -4.0, lowest_mps2  # and none starts with an emergency stop (SUMO's: -9 m/s^2)


def test_the_core_draws_any_egos_frame_and_its_one_ego_draws_the_gymnasium_envs(small_config):
    """render() is the first ego's frame; each ego's frame is drawn around it; the Gymnasium env's frame is its
    core's one ego's, pixel for pixel, for the same seed and actions."""
    env = sumo_rail.parallel_env(egos=2, config=small_config, render_mode="rgb_array")
    try:
        env.reset(seed=3)
        env.step({agent: int(Action.KEEP) for agent in env.agents})
        first, second = env.frame("ego_0"), env.frame("ego_1")
        assert first.dtype == np.uint8 and first.ndim == 3 and np.array_equal(env.render(), first)
        assert not np.array_equal(first, second)
    finally:
        env.close()
    single, core = HighwayEnv(small_config, render_mode="rgb_array"), sumo_rail.parallel_env(config=small_config)
    try:
        single.reset(seed=5)
        core.reset(seed=5)
        for action in (Action.ACCELERATE, Action.LANE_LEFT, Action.KEEP):
            single.step(int(action))
            core.step({"ego_0": int(action)})
        assert core.render() is None and np.array_equal(single.render(), core.frame())
    finally:
        single.close()
        core.close()
