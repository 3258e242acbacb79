"""The roads of scenario.kind driven in SUMO: their route frame, the expert's manoeuvres, a user's own network and
what bad input says."""

from __future__ import annotations

import dataclasses
import subprocess
from pathlib import Path

import libsumo
import numpy as np
import pandas as pd
import pytest

from sumo_rail.config import Config, ConfigError
from sumo_rail.drivers.expert import make_expert
from sumo_rail.sim import lidar, network
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.parallel_env import ParallelHighwayEnv
from sumo_rail.sim.road import RouteMap, RouteView
from sumo_rail.sim.simulation import EgoCouldNotEnter, Simulation

FEATURE = {"feature_at_m": 750.0, "feature_length_m": 250.0}
"""The small test road's feature: past its start window (300 m to 500 m), 400 m before its end at 1500 m."""


def road(small_config: Config, kind: str, **scenario: object) -> Config:
    return small_config.with_overrides({"scenario": {"kind": kind, **FEATURE, **scenario},
                                        "observation": {"lane_block": 1, "route_block": 1}})


def drive(env: HighwayEnv, seed: int) -> tuple[dict, list[float], list[str]]:
    """One episode of the normal expert: its last info, the ego's route positions and SUMO lane ids."""
    cfg = env.config
    expert = make_expert("normal", cfg.env.speed_step_mps, cfg.expert.view_range_m)
    observation, info = env.reset(seed=seed)
    positions, lane_ids = [], []
    done = False
    while not done:
        assert env.observation_space.contains(observation)
        positions.append(env.traffic.ego.lane_position_m)
        lane_ids.append(env.traffic.ego.lane_id)
        observation, _, terminated, truncated, info = env.step(expert(observation, env.traffic))
        done = terminated or truncated
    return info, positions, lane_ids


def view_as_computed_before(route_map: RouteMap, lane_id: str, position_m: float) -> RouteView:
    """`RouteMap.view` as it was before it kept each lane's neighbours and bisected the merge and diverge points."""
    lowest, highest = route_map.edge_lanes(lane_id)
    edge = lane_id.rpartition("_")[0]
    ids = [f"{edge}_{index}" for index in range(highest - lowest + 1)] if edge in route_map._edges else [lane_id]
    lane_end = tuple(route_map._lane_ends.get(lane, position_m) - position_m for lane in ids)
    merge = min((at - position_m for at in route_map.merges_m if at > position_m), default=np.inf)
    diverge = min((at - position_m for at in route_map.diverges_m if at > position_m), default=np.inf)
    return RouteView(lowest, highest, lane_end, merge, diverge, route_map.length_m - position_m)


@pytest.mark.parametrize("kind", ["merge", "merge_from_ramp", "lane_drop", "exit"])
def test_each_roads_route_frame_numbers_lanes_from_the_main_roads_right_and_knows_where_lanes_end(small_config, kind):
    config = road(small_config, kind)
    sim = Simulation(config.scenario, 120.0)
    try:
        route_map = sim.route_map
        start_lanes = sim.start_lanes
    finally:
        sim.close()
    first_edge = route_map.route[0]
    views = {lane: route_map.view(f"{first_edge}_{lane}", 400.0) for lane in range(start_lanes)}
    positions = [*route_map.merges_m, *route_map.diverges_m, *np.random.default_rng(35).uniform(-50.0, 1600.0, 40)]
    for lane_id in route_map.lane_places:  # the view (cached per lane, points found by bisection) as it was computed
        for position_m in positions:
            assert route_map.view(lane_id, position_m) == view_as_computed_before(route_map, lane_id, position_m)
    if kind == "merge_from_ramp":  # the ramp (-1) leads into the acceleration lane, which ends after the feature
        assert start_lanes == 1 and views[0].lowest_lane == views[0].highest_lane == -1
        assert 750.0 + 250.0 - 20.0 < views[0].lane_end(-1) + 400.0 < 750.0 + 250.0 + 20.0
        assert route_map.merges_m and not route_map.diverges_m
    elif kind == "lane_drop":  # the two right lanes end at the work zone, the others lead to the route's end
        ends = [views[0].lane_end(lane) + 400.0 for lane in range(5)]
        assert all(740.0 < end < 760.0 for end in ends[:2]) and ends[2:] == [np.inf] * 3
        assert views[0].best_lane_offset(0) == 2 and views[0].best_lane_offset(3) == 0
    elif kind == "exit":  # only the rightmost lane reaches the off-ramp
        assert views[0].lane_end(0) == np.inf and all(740.0 < views[0].lane_end(lane) + 400 < 760.0
                                                      for lane in range(1, 5))
        assert views[0].best_lane_offset(4) == -4 and route_map.diverges_m
    else:  # the main road goes on; the acceleration lane beside it is lane -1 and ends
        assert views[0].lowest_lane == 0 and views[0].highest_lane == 4 and route_map.merges_m
        merge_edge = route_map.route[1]
        assert route_map.edge_lanes(f"{merge_edge}_0") == (-1, 4)
        assert route_map.place(f"{merge_edge}_0", 10.0)[1] == -1


@pytest.mark.parametrize("kind", ["merge_from_ramp", "lane_drop", "exit"])
def test_the_expert_completes_each_roads_manoeuvre(small_config, kind):
    env = HighwayEnv(road(small_config, kind))
    try:
        seed = 0
        while kind == "lane_drop" and env.reset(seed=seed)[1]["lane"] >= 2:  # a start in a lane that ends
            seed += 1
        info, positions, lane_ids = drive(env, seed)
    finally:
        env.close()
    assert info["termination"] == "end_of_road" and info["collisions"] == 0 and info["teleports"] == 0
    assert info["missed_exits"] == 0 and info["lane_end_stops"] == 0
    assert np.all(np.diff(positions) >= 0)  # the route frame runs on across every joint
    if kind == "exit":
        assert lane_ids[-1].startswith("off_ramp")
    else:
        assert info["merges"] == 1


def test_a_driver_that_ignores_the_route_stops_at_the_lane_end_and_fails(small_config):
    env = HighwayEnv(road(small_config, "exit"))
    try:
        seed = 0
        while env.reset(seed=seed)[1]["lane"] == 0:  # a start in a lane that does not reach the exit
            seed += 1
        done = False
        while not done:
            _, reward, terminated, truncated, info = env.step(0)  # keep: never moves right
            done = terminated or truncated
        assert "ego" not in libsumo.vehicle.getIDList()  # taken off the lane it would block
    finally:
        env.close()
    assert terminated and info["termination"] == "missed_exit" and info["missed_exits"] == 1
    assert reward <= env.config.env.collision_reward + 1.0


def bend_network(folder: Path, config: Config) -> Config:
    """`config` on a user's network built with netconvert in `folder`: a bend where the road narrows from 3 lanes
    to 2, 1500 veh/h, with the route block."""
    (folder / "road.nod.xml").write_text(
        '<nodes><node id="a" x="0" y="0"/><node id="b" x="900" y="0"/><node id="c" x="1500" y="400"/></nodes>')
    (folder / "road.edg.xml").write_text(
        '<edges><edge id="first" from="a" to="b" numLanes="3" speed="30"/>'
        '<edge id="second" from="b" to="c" numLanes="2" speed="30"/></edges>')
    net = folder / "road.net.xml"
    subprocess.run([network.sumo_binary("netconvert"), "--node-files", str(folder / "road.nod.xml"),
                    "--edge-files", str(folder / "road.edg.xml"), "-o", str(net), "--no-turnarounds", "true"],
                   check=True, capture_output=True)
    return config.with_overrides({"scenario": {"kind": "network", "network": str(net), "route": "first second",
                                               "lanes": 3, "flow_veh_per_h": 1500.0},
                                  "observation": {"route_block": 1}})


def test_a_user_network_built_with_netconvert_is_driven_along_its_route(small_config, tmp_path):
    """A bend where the road narrows from 3 lanes to 2, in a network of the user's own."""
    config = bend_network(tmp_path, small_config)
    env = HighwayEnv(config)
    try:
        info, positions, lane_ids = drive(env, 1)
    finally:
        env.close()
    assert info["termination"] == "end_of_road" and info["collisions"] == 0 and info["lane_end_stops"] == 0
    assert lane_ids[0].startswith("first") and lane_ids[-1].startswith("second")
    assert np.all(np.diff(positions) >= 0) and positions[-1] > 900.0


@pytest.mark.parametrize(("overrides", "message"), [
    ({"kind": "roundabout"}, "unknown scenario.kind 'roundabout'"),
    ({"kind": "exit", "feature_at_m": 1400.0}, "must lie between 200 m and 400 m before the road's end"),
    ({"kind": "lane_drop", "dropped_lanes": 5}, "scenario.dropped_lanes must be between 1 and"),
    ({"kind": "network"}, "needs scenario.network"),
    ({"kind": "merge", "feature_at_m": 600.0}, "must end at least 200 m before"),
])
def test_impossible_roads_are_one_sentence(small_config, overrides, message):
    with pytest.raises(ConfigError, match=message):
        small_config.with_overrides({"scenario": {**FEATURE, **overrides}})


def test_bad_user_networks_name_the_problem(small_config, tmp_path):
    def built(**scenario: object) -> None:
        network.build(small_config.with_overrides({"scenario": {"kind": "network", **scenario}}).scenario)

    with pytest.raises(ConfigError, match=r"cannot read scenario\.network"):
        built(network=str(tmp_path / "missing.net.xml"), route="a")
    (tmp_path / "routes.xml").write_text("<routes/>")
    with pytest.raises(ConfigError, match="is not a SUMO network"):
        built(network=str(tmp_path / "routes.xml"), route="a")
    straight = network.build(small_config.scenario).net_file
    with pytest.raises(ConfigError, match="edge 'nowhere' is not in"):
        built(network=str(straight), route="highway nowhere")
    with pytest.raises(ConfigError, match=r"set --set scenario\.lanes=5"):
        built(network=str(straight), route="highway", lanes=3)
    text = straight.read_text()
    (tmp_path / "bad_length.net.xml").write_text(text.replace('length="', 'length="x', 1))
    with pytest.raises(ConfigError, match=r"bad_length\.net\.xml is a damaged SUMO network"):
        built(network=str(tmp_path / "bad_length.net.xml"), route="highway")
    dangling = '<connection from="highway" to="gone" fromLane="0" toLane="0"/></net>'
    (tmp_path / "no_edge.net.xml").write_text(text.replace("</net>", dangling))
    with pytest.raises(ConfigError, match=r"no_edge\.net\.xml is a damaged SUMO network"):
        built(network=str(tmp_path / "no_edge.net.xml"), route="highway")
    (tmp_path / "no_shape.net.xml").write_text(text.replace(' shape="', ' form="'))
    with pytest.raises(ConfigError, match=r"SUMO cannot load scenario\.network no_shape\.net\.xml: .*shape"):
        built(network=str(tmp_path / "no_shape.net.xml"), route="highway")
    # the bend's third lane ends after its start: its two lanes jam beyond 2000 veh/h a lane, not 3000
    bend = bend_network(tmp_path, small_config).with_overrides({"scenario": {"flow_veh_per_h": 5000.0}})
    with pytest.raises(ConfigError, match=r"more than the route's narrowest edge in road\.net\.xml \(2 lanes\) "
                                          r"can carry \(about 2000 veh/h a lane\)"):
        network.build(bend.scenario)
    # a route whose start is its narrowest part queues there, off the road, as the generated roads do: accepted
    built(network=str(straight), route="highway", flow_veh_per_h=12000.0)


def test_a_crowded_start_is_drawn_again_the_same_way_for_every_driver(small_config, monkeypatch):
    """The first drawn place is full: the ego starts at the next drawn place, the same for every reset of the seed;
    with no room anywhere the reset says so in one sentence."""
    reset = Simulation.reset_egos
    places: list[tuple[int, float]] = []

    def first_place_full(sim, warm_state, sumo_seed, egos, pool="train"):
        places.append(tuple(egos[0][1:]))
        if len(places) % 2 == 1:
            raise EgoCouldNotEnter("the ego could not enter")
        return reset(sim, warm_state, sumo_seed, egos, pool)

    monkeypatch.setattr(Simulation, "reset_egos", first_place_full)
    env = HighwayEnv(small_config)
    try:
        first, _ = env.reset(seed=4)
        again, _ = env.reset(seed=4)
        assert places[0] != places[1] and places[1] == places[3] and np.array_equal(first, again)
        monkeypatch.setattr(Simulation, "reset_egos",
                            lambda *args, **kwargs: (_ for _ in ()).throw(EgoCouldNotEnter("")))
        with pytest.raises(EgoCouldNotEnter, match="no room at 20 places of its start window"):
            env.reset(seed=5)
    finally:
        env.close()


def test_a_crowded_start_on_the_shared_road_is_drawn_again_as_the_single_egos(small_config, monkeypatch):
    """record-expert, dagger and RAIL drive their episodes on the shared road (one ego or K): a first place with no
    room is drawn again there too, one ego's exactly as `HighwayEnv` draws it (the same episode), K egos' when none
    of them entered; with no room anywhere the reset says so in one sentence."""
    reset_egos = Simulation.reset_egos
    places: list[list[tuple[int, float]]] = []

    def first_place_full(sim, warm_state, sumo_seed, egos, pool="train"):
        places.append([(lane, position_m) for _, lane, position_m in egos])
        if len(places) % 2 == 1:
            raise EgoCouldNotEnter("no ego could enter")
        return reset_egos(sim, warm_state, sumo_seed, egos, pool)

    monkeypatch.setattr(Simulation, "reset_egos", first_place_full)
    single = HighwayEnv(small_config)
    try:
        want, _ = single.reset(seed=4)
    finally:
        single.close()
    for egos in (1, 2):
        shared = ParallelHighwayEnv(egos, small_config)
        try:
            observations, _ = shared.reset(seed=4)
            assert set(observations) == set(shared.possible_agents) and places[-2] != places[-1]
            if egos == 1:
                assert places[2:] == places[:2] and np.array_equal(observations["ego_0"], want)
            monkeypatch.setattr(Simulation, "reset_egos",
                                lambda *args, **kwargs: (_ for _ in ()).throw(EgoCouldNotEnter("")))
            with pytest.raises(EgoCouldNotEnter, match=("the ego found no room" if egos == 1 else
                                                        "none of the 2 egos found room") + " at 20 places of"):
                shared.reset(seed=5)
            monkeypatch.setattr(Simulation, "reset_egos", first_place_full)
        finally:
            shared.close()


def test_straight_roads_route_frame_is_sumos_own_numbering(small_config):
    sim = Simulation(small_config.scenario, 120.0)
    try:
        assert sim.route_map.single_edge and sim.route_map.length_m == small_config.scenario.length_m
        assert sim.route_map.place("highway_3", 123.25) == (123.25, 3)
        assert dataclasses.astuple(sim.route_map.view("highway_2", 100.0))[2] == (np.inf,) * 5
    finally:
        sim.close()


def test_the_cli_takes_a_road_by_its_bare_name_and_records_it_in_the_outputs_provenance(tmp_path):
    from click.testing import CliRunner
    from sumo_rail_cli.main import cli

    from sumo_rail.datasets import read_metadata

    small = ["--set", "scenario.length_m=1500", "--set", "scenario.warmup_s=60", "--set", "scenario.snapshots=2",
             "--set", "env.ego_start_min_m=300", "--set", "env.ego_start_max_m=500",
             *[part for key, value in FEATURE.items() for part in ("--set", f"scenario.{key}={value}")]]
    out = tmp_path / "metrics.parquet"
    result = CliRunner().invoke(cli, ["evaluate", "--set", "scenario.kind=lane_drop", *small, "--policy", "expert",
                                      "--episodes", "1", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert read_metadata(out)["config"]["scenario"]["kind"] == "lane_drop"
    assert "lane_end_stops" in pd.read_parquet(out).columns
    result = CliRunner().invoke(cli, ["evaluate", "--set", "scenario.kind=network", "--set",
                                      f"scenario.network={tmp_path / 'none.net.xml'}", "--set", "scenario.route=a",
                                      "--policy", "expert", "--episodes", "1", "--out", str(tmp_path / "x.parquet")])
    assert result.exit_code == 2 and "cannot read scenario.network" in result.output
    assert not (tmp_path / "x.parquet").exists()


def test_set_reads_bare_words_and_edge_lists_as_strings_and_numbers_as_numbers():
    from sumo_rail_cli.settings import resolve_settings

    from sumo_rail.setting_tables import read_assignments

    scenario = read_assignments(("scenario.route=e1 e2", "scenario.flow_veh_per_h=2000",
                                 'scenario.traffic_file="my file.rou.xml"'))["scenario"]
    assert scenario == {"route": "e1 e2", "flow_veh_per_h": 2000, "traffic_file": "my file.rou.xml"}
    with pytest.raises(Exception, match="unreadable value"):
        resolve_settings("paper", None, ('scenario.route="e1',))[0]
    with pytest.raises(Exception, match="must be a number"):
        resolve_settings("paper", None, ("scenario.flow_veh_per_h=lots",))[0]


def test_several_egos_share_a_ramp_and_respawn_on_it(small_config):
    """The multi-ego env on merge_from_ramp: egos start on the route's first edge (the one-lane ramp), drive across
    the joints, and an ended ego respawns there while the others drive on."""
    from sumo_rail.sim.parallel_env import ParallelHighwayEnv

    env = ParallelHighwayEnv(2, road(small_config, "merge_from_ramp"))
    expert = make_expert("normal", env.config.env.speed_step_mps, env.config.expert.view_range_m)
    try:
        observations, _ = env.reset(seed=2)
        assert {env.traffic(agent).ego.lane_id for agent in env.agents} == {"ramp_0"}
        ended: set[str] = set()
        for _ in range(400):
            actions = {agent: expert(observations[agent], env.traffic(agent)) for agent in env.agents}
            observations, _, terminations, truncations, infos = env.step(actions)
            for agent in actions:
                if terminations[agent] or truncations[agent]:
                    assert infos[agent]["termination"] == "end_of_road" and infos[agent]["merges"] == 1
                    ended.add(agent)
                    observations[agent], _ = env.respawn(agent)
                    assert env.traffic(agent).ego.lane_id == "ramp_0"
            if len(ended) == 2:
                break
        assert ended == {"ego_0", "ego_1"}
    finally:
        env.close()


def test_a_flow_no_road_can_hold_is_refused_before_anything_runs(small_config):
    with pytest.raises(ConfigError, match=r"more than 5 lanes can carry"):
        small_config.with_overrides({"scenario": {"flow_veh_per_h": 20000.0}})
    with pytest.raises(ConfigError, match=r"ramp_flow_veh_per_h must be between 0 and 3000 veh/h"):
        small_config.with_overrides({"scenario": {"kind": "merge", **FEATURE, "ramp_flow_veh_per_h": 5000.0}})
    with pytest.raises(ConfigError, match=r"more than the work zone's 1 lane can carry"):
        small_config.with_overrides({"scenario": {"kind": "lane_drop", **FEATURE, "dropped_lanes": 4,
                                                  "flow_veh_per_h": 12000.0}})
    # the work zone jams where the road's start would let the traffic in (experiments/road_capacity.py)
    with pytest.raises(ConfigError, match=r"\(8000 veh/h\) is more than the work zone's 3 lanes can carry "
                                          r"\(about 2000 veh/h a lane\)"):
        small_config.with_overrides({"scenario": {"kind": "lane_drop", **FEATURE, "flow_veh_per_h": 8000.0}})
    small_config.with_overrides({"scenario": {"kind": "lane_drop", **FEATURE, "flow_veh_per_h": 6000.0}})
    with pytest.raises(ConfigError, match=r"exit_share \(1600 veh/h\) is more than the exit takes"):
        small_config.with_overrides({"scenario": {"kind": "exit", **FEATURE, "flow_veh_per_h": 8000.0}})
    small_config.with_overrides({"scenario": {"kind": "exit", **FEATURE, "flow_veh_per_h": 8000.0, "exit_share": 0.1}})
    with pytest.raises(ConfigError, match=r"plus scenario\.ramp_flow_veh_per_h \(17000 veh/h\) is more than the 5"):
        small_config.with_overrides({"scenario": {"kind": "merge", **FEATURE, "flow_veh_per_h": 14000.0,
                                                  "ramp_flow_veh_per_h": 3000.0}})


@pytest.mark.parametrize("kind", ["straight", "merge", "lane_drop", "exit"])
def test_no_lidar_beam_leaves_the_road_through_a_junction(small_config, kind):
    """Across every joint of a road (a ramp's, a work zone's, an exit's), a beam from the main road crossing its
    side hits it: the junctions' outer sides are walls as the edges' are (the straight road has none)."""
    config = road(small_config, kind)
    env = HighwayEnv(config)
    try:
        env.reset(seed=1)
        walls = np.concatenate([env.simulation.road_edges(), env.simulation.junction_edges()])
        assert kind != "straight" or len(env.simulation.junction_edges()) == 0
    finally:
        env.close()
    boxes, centre_m = lidar.edge_boxes(walls), -config.scenario.lanes * config.scenario.lane_width_m / 2
    # beams at least 20 degrees off the road's axis, from the middle of the main road, reach a side within range
    across = np.abs(np.sin(lidar.beam_angles(72, 0.0))) >= np.sin(np.radians(20.0))
    for joint_m in (750.0, 1000.0):
        for x in np.arange(joint_m - 20.0, joint_m + 20.0, 1.0):
            distances, _ = lidar.scan(np.array([x, centre_m]), 0.0, np.zeros(2), boxes, 72, 100.0)
            assert distances[across].max() < 100.0, (kind, x)


ROUTE_VALUES_AT_START = {  # which of (merge ahead, diverge ahead) each road has in range at the start window
    "straight": (False, False), "merge": (True, False), "merge_from_ramp": (True, False),
    "lane_drop": (False, False), "exit": (False, True)}


@pytest.mark.parametrize("kind", list(ROUTE_VALUES_AT_START))
def test_the_route_block_holds_each_road_s_own_merge_and_diverge(small_config, kind):
    """At the first decision: a merge ahead on the merges (the ramp joins at feature_at_m), a diverge on the exit
    (and the ego's lane leading only as far as it, two lanes left of the exit lane), nothing on the others; each
    distance the feature's own from the ego's front, / observation.route_range_m. Swapping merge and diverge, or a
    wrong scale, fails here (the digests of test_road_reference only say that something changed)."""
    from sumo_rail.sim.observation import observation_names

    config = road(small_config, kind)
    env = HighwayEnv(config)
    try:
        observation, _ = env.reset(seed=0)
        front_m = libsumo.vehicle.getLanePosition("ego")
        lane = libsumo.vehicle.getLaneIndex("ego")
    finally:
        env.close()
    names = observation_names(config)
    lane_end, offset, merge, diverge = (float(observation[names.index(field)]) for field in
                                        ("route_lane_end", "route_lane_offset", "route_merge_ahead",
                                         "route_diverge_ahead"))
    range_m = config.observation.route_range_m
    feature_share = (FEATURE["feature_at_m"] - front_m) / range_m
    merge_ahead, diverge_ahead = ROUTE_VALUES_AT_START[kind]
    assert merge == (pytest.approx(feature_share, abs=0.02) if merge_ahead and kind == "merge" else merge)
    assert (merge < 1.0) == merge_ahead and (diverge < 1.0) == diverge_ahead
    if kind == "exit":
        assert diverge == pytest.approx(feature_share, abs=0.02) and lane_end == pytest.approx(diverge)
        assert offset == pytest.approx(-lane / (config.scenario.lanes - 1))
    else:
        assert (lane_end, offset) == (1.0, 0.0)
