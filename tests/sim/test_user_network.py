"""A user's own network (scenario.kind network) and traffic file: what is refused before any work, in one sentence,
and what SUMO itself takes is taken."""

from __future__ import annotations

import gzip
import subprocess
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest

from sumo_rail.config import Config, ConfigError
from sumo_rail.sim import network, user_network

ROUTES = '<routes><vType id="{type}" vClass="passenger"/>' \
         '<flow id="mine" from="first" to="second" type="{type}" begin="0" end="{end}" period="5"/></routes>'
"""A user's traffic file: a flow of its own vehicle type (`type`, defined here) until `end` [s]."""


def two_edges(folder: Path, first: str = 'numLanes="2"', node: str = "priority", length_m: float = 900.0) -> Path:
    """A network built with netconvert in `folder`: edge "first" (`first`'s attributes) of `length_m`, then
    "second" (2 lanes, 600 m), joined at a node of type `node`."""
    (folder / "road.nod.xml").write_text(
        f'<nodes><node id="a" x="0" y="0"/><node id="b" x="{length_m}" y="0" type="{node}"/>'
        f'<node id="c" x="{length_m + 600}" y="0"/></nodes>')
    (folder / "road.edg.xml").write_text(
        f'<edges><edge id="first" from="a" to="b" {first} speed="30"/>'
        '<edge id="second" from="b" to="c" numLanes="2" speed="30"/></edges>')
    net = folder / "road.net.xml"
    subprocess.run([network.sumo_binary("netconvert"), "--node-files", str(folder / "road.nod.xml"),
                    "--edge-files", str(folder / "road.edg.xml"), "-o", str(net), "--no-turnarounds", "true"],
                   check=True, capture_output=True)
    return net


def on(config: Config, net: Path, lanes: int = 2, **scenario: object) -> Config:
    return config.with_overrides({"scenario": {"kind": "network", "network": str(net), "route": "first second",
                                               "lanes": lanes, **scenario}})


def test_the_start_window_is_checked_against_the_routes_own_length(small_config, tmp_path):
    # scenario.length_m (1500 m) would hold the window and margin (500 m + 300 m); the route (about 750 m) does not
    short = on(small_config.with_overrides({"env": {"end_margin_m": 300.0}}), two_edges(tmp_path, length_m=150.0))
    with pytest.raises(ConfigError, match=r"\(800 m\) must be shorter than scenario\.route \(7\d\d m long in "
                                          r"road\.net\.xml\)"):
        user_network.check_start_window(short.env, network.build(short.scenario))
    # a route (2600 m) that holds the window, on a config whose scenario.length_m (600 m) would not
    long = on(small_config.with_overrides({"scenario": {"length_m": 600.0}, "env": {"end_margin_m": 50.0}}),
              two_edges(tmp_path, length_m=2000.0))
    user_network.check_start_window(long.env, network.build(long.scenario))


@pytest.mark.parametrize("setting", ["network", "route", "traffic_file"])
def test_a_users_road_settings_with_a_generated_road_are_refused(small_config, setting):
    with pytest.raises(ConfigError, match=rf"scenario\.{setting} only serves scenario\.kind network, not merge; drop"):
        small_config.with_overrides({"scenario": {"kind": "merge", "feature_at_m": 750.0, setting: "x"}})


def test_an_edge_the_ego_may_not_use_is_named_before_any_work(small_config, tmp_path):
    bus_only = on(small_config, two_edges(tmp_path, first='numLanes="2" allow="bus"'))
    with pytest.raises(ConfigError, match=r"edge 'first' in road\.net\.xml has no lane a passenger car may use"):
        network.build(bus_only.scenario)


def test_lanes_advice_is_never_a_value_that_is_then_refused(small_config, tmp_path):
    wide = on(small_config, two_edges(tmp_path, first='numLanes="12"'))
    with pytest.raises(ConfigError, match=r"has 12 lanes; scenario\.lanes must be between 1 and 10") as error:
        network.build(wide.scenario)
    assert "--set" not in str(error.value)


def test_a_route_with_a_traffic_light_is_refused(small_config, tmp_path):
    lit = on(small_config, two_edges(tmp_path, node="traffic_light"))
    with pytest.raises(ConfigError, match=r"edge 'first' in road\.net\.xml ends at a traffic light"):
        network.build(lit.scenario)


def test_a_traffic_file_that_leaves_the_road_empty_is_refused(small_config, tmp_path):
    net = two_edges(tmp_path)
    (tmp_path / "net_as_traffic.xml").write_bytes(net.read_bytes())
    with pytest.raises(ConfigError, match=r"net_as_traffic\.xml is not a SUMO route file"):
        network.build(on(small_config, net, traffic_file=str(tmp_path / "net_as_traffic.xml")).scenario)
    # the small config's warm-up and snapshots last 120 s + 3 x 10 s
    (tmp_path / "early.rou.xml").write_text(ROUTES.format(type="mine", end=149))
    with pytest.raises(ConfigError, match=r"departs its last vehicle at 149 s, before the warm-up and its "
                                          r"snapshots end at 150 s, so the road would be empty"):
        network.build(on(small_config, net, traffic_file=str(tmp_path / "early.rou.xml")).scenario)
    (tmp_path / "enough.rou.xml").write_text(ROUTES.format(type="mine", end=150))
    network.build(on(small_config, net, traffic_file=str(tmp_path / "enough.rou.xml")).scenario)


@pytest.mark.parametrize("vehicle_type", ["car", "truck", "traffic"])
def test_a_traffic_file_may_define_or_use_the_built_in_type_names(small_config, tmp_path, vehicle_type):
    net = two_edges(tmp_path)
    (tmp_path / "own.rou.xml").write_text(ROUTES.format(type=vehicle_type, end=1000))
    network.build(on(small_config, net, traffic_file=str(tmp_path / "own.rou.xml")).scenario)
    used = ROUTES.format(type="unused", end=1000).replace('type="unused"', f'type="{vehicle_type}"')
    (tmp_path / "uses.rou.xml").write_text(used)
    network.build(on(small_config, net, traffic_file=str(tmp_path / "uses.rou.xml")).scenario)


def test_a_compressed_network_is_taken_and_a_sumo_configuration_is_refused(small_config, tmp_path):
    net = two_edges(tmp_path)
    packed = tmp_path / "road.net.xml.gz"
    packed.write_bytes(gzip.compress(net.read_bytes()))
    assert network.build(on(small_config, packed).scenario).net_file == packed
    (tmp_path / "run.sumocfg").write_text('<configuration><input><net-file value="road.net.xml"/>'
                                          '<route-files value="cars.rou.xml"/></input></configuration>')
    with pytest.raises(ConfigError, match=r"run\.sumocfg is a SUMO configuration, not a network: give its net-file "
                                          r"\(road\.net\.xml\) as scenario\.network and its route-files "
                                          r"\(cars\.rou\.xml\) as scenario\.traffic_file$"):
        network.build(on(small_config, tmp_path / "run.sumocfg").scenario)


def test_a_users_files_are_found_from_the_toml_kept_absolute_and_pinned_by_their_hash(small_config, tmp_path,
                                                                                       monkeypatch):
    from sumo_rail_cli.settings import resolve_settings

    from sumo_rail.datasets import file_sha256
    from sumo_rail.learning.run_folder import RunError, check_resumable, start_run_folder
    from sumo_rail.runners.tables import ROAD_FILES, provenance

    road = tmp_path / "road"
    road.mkdir()
    net = two_edges(road)
    (road / "cars.rou.xml").write_text(ROUTES.format(type="car", end=1e6))
    (road / "road.toml").write_text('[scenario]\nkind = "network"\nnetwork = "road.net.xml"\nroute = "first second"\n'
                                    'lanes = 2\ntraffic_file = "cars.rou.xml"\n')
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    config, _ = resolve_settings("paper", Path("../road/road.toml"), ())
    assert config.scenario.network == str(net) and config.scenario.traffic_file == str(road / "cars.rou.xml")
    record = {"settings": {}, **provenance("training_run", config, 0)}
    cars = road / "cars.rou.xml"
    assert record[ROAD_FILES] == {str(net): file_sha256(net), str(cars): file_sha256(cars)}
    start_run_folder(tmp_path / "run", record)
    (tmp_path / "run" / "checkpoint.pt").write_bytes(b"")
    check_resumable(tmp_path / "run", "checkpoint.pt", record)
    net.write_bytes(net.read_bytes().replace(b'speed="30.00"', b'speed="20.00"'))
    changed = {"settings": {}, **provenance("training_run", config, 0)}
    with pytest.raises(RunError, match=rf"{net} has changed since run .* was started on it"):
        check_resumable(tmp_path / "run", "checkpoint.pt", changed)


def test_the_set_point_keeps_to_a_slower_roads_limit_and_its_reward_is_full_there(small_config, tmp_path):
    from sumo_rail.sim.actions import Action
    from sumo_rail.sim.env import HighwayEnv

    net = two_edges(tmp_path, length_m=1500.0)
    net.write_bytes(net.read_bytes().replace(b'speed="30.00"', b'speed="20.00"'))
    config = on(small_config, net, flow_veh_per_h=100.0)
    assert config.env.v_max_mps > 20.0
    env = HighwayEnv(config)
    try:
        env.reset(seed=0)
        infos = [env.step(int(Action.ACCELERATE))[4] for _ in range(30)]
    finally:
        env.close()
    assert max(info["set_point_mps"] for info in infos) == 20.0
    fast = [info for info in infos if info["speed_mps"] >= 19.9]
    assert fast and all(info["reward_longitudinal"] == 1.0 for info in fast)
    assert max(info["speed_mps"] for info in infos) < 20.5


def test_a_route_slower_than_the_lowest_set_point_is_refused(small_config, tmp_path):
    net = two_edges(tmp_path)
    net.write_bytes(net.read_bytes().replace(b'speed="30.00"', b'speed="8.00"'))
    config = on(small_config, net)
    with pytest.raises(ConfigError, match=r"speed limit in road\.net\.xml \(8 m/s\) must be above env\.v_min_mps"):
        user_network.check_start_window(config.env, network.build(config.scenario))


def test_the_docs_name_netconvert_the_projects_type_names_and_how_long_user_traffic_must_run():
    from sumo_rail.sim import scenarios

    docs = (Path(__file__).parents[2] / "docs" / "scenarios.md").read_text()
    assert ".venv/bin/netconvert" in docs
    types = ElementTree.parse(network.sources_dir() / scenarios.VEHICLE_TYPES_FILE).getroot()
    for element in [*types.iter("vType"), *types.iter("vTypeDistribution")]:
        assert f"`{element.get('id')}`" in docs
    defaults = Config().scenario
    needed = defaults.warmup_s + defaults.snapshots * defaults.snapshot_interval_s
    assert f"{defaults.warmup_s:g} + {defaults.snapshots} x {defaults.snapshot_interval_s:g} = {needed:g} s" in docs


def test_an_env_built_from_python_checks_the_route_s_length_before_sumo_starts(small_config, tmp_path):
    """The CLI's check, for a user who builds the env in Python (Gymnasium's make, a vector env)."""
    from sumo_rail.sim.env import HighwayEnv
    from sumo_rail.sim.parallel_env import ParallelHighwayEnv

    short = on(small_config.with_overrides({"env": {"end_margin_m": 300.0}}), two_edges(tmp_path, length_m=150.0))
    for env in (HighwayEnv(short), ParallelHighwayEnv(2, short)):
        with pytest.raises(ConfigError, match=r"must be shorter than scenario\.route"):
            env.reset(seed=0)
        env.close()


def exit_road(folder: Path) -> Path:
    """A motorway with an off-ramp as the OpenStreetMap walk-through builds it (netconvert --ramps.guess): "main1"
    (3 lanes, ~1 km), its added deceleration lane "main1-AddedOffRampEdge", then "main2" (3 lanes) or "exit"."""
    (folder / "exit.nod.xml").write_text('<nodes><node id="a" x="0" y="0"/><node id="b" x="1100" y="0"/>'
                                         '<node id="c" x="2000" y="0"/><node id="r" x="1400" y="-150"/></nodes>')
    (folder / "exit.edg.xml").write_text(
        '<edges><edge id="main1" from="a" to="b" numLanes="3" speed="33.33" priority="3"/>'
        '<edge id="main2" from="b" to="c" numLanes="3" speed="33.33" priority="3"/>'
        '<edge id="exit" from="b" to="r" numLanes="1" speed="22.22" priority="1"/></edges>')
    net = folder / "exit.net.xml"
    subprocess.run([network.sumo_binary("netconvert"), "--node-files", str(folder / "exit.nod.xml"),
                    "--edge-files", str(folder / "exit.edg.xml"), "-o", str(net), "--ramps.guess",
                    "--no-turnarounds", "true"], check=True, capture_output=True)
    return net


EXIT_ROUTE = "main1 main1-AddedOffRampEdge exit"


def test_generated_traffic_takes_the_exit_at_exit_share_and_the_rest_the_main_road(small_config, tmp_path):
    config = on(small_config, exit_road(tmp_path), lanes=4, route=EXIT_ROUTE, flow_veh_per_h=1800.0)
    root = ElementTree.parse(network.build(config.scenario).routes_file).getroot()
    routes = {route.get("id"): route.get("edges") for route in root.iter("route")}
    flows = {flow.get("route"): flow.get("period") for flow in root.iter("flow")}
    assert routes["main_road"] == "main1 main1-AddedOffRampEdge main2" and routes["ego_route"] == EXIT_ROUTE
    assert flows == {"main_road": f"exp({1800 * 0.8 / 3600!r})", "ego_route": f"exp({1800 * 0.2 / 3600!r})"}
    straight = on(small_config, two_edges(tmp_path))  # a route along the main road: one flow along it, as before
    assert [flow.get("route") for flow in ElementTree.parse(network.build(straight.scenario).routes_file)
            .getroot().iter("flow")] == ["ego_route"]


def test_the_expert_takes_its_routes_exit_on_a_users_motorway(small_config, tmp_path):
    """The walk-through's road: with all generated traffic queueing into the exit, the expert missed it in 12 of 80
    episodes; with the traffic split at the exit, in none."""
    config = on(small_config, exit_road(tmp_path), lanes=4, route=EXIT_ROUTE, flow_veh_per_h=1500.0).with_overrides(
        {"env": {"ego_start_min_m": 300.0, "ego_start_max_m": 700.0}, "observation": {"route_block": 1}})
    assert expert_terminations(config, 30) == ["end_of_road"] * 30


def expert_terminations(config: Config, episodes: int) -> list[str]:
    """How each of the expert's episodes on seeds 0, 1, ... ended (`termination`)."""
    from sumo_rail.runners.rollout import ExpertDriver
    from sumo_rail.sim.env import HighwayEnv

    env = HighwayEnv(config)
    expert = ExpertDriver().create(config, 0)
    terminations = []
    try:
        for seed in range(episodes):
            observation, _ = env.reset(seed=seed)
            done = False
            while not done:
                observation, _, terminated, truncated, info = env.step(expert(observation, env.traffic))
                done = terminated or truncated
            terminations.append(info["termination"])
    finally:
        env.close()
    return terminations


def test_several_egos_start_slots_are_checked_against_the_routes_own_length(small_config, tmp_path):
    """scenario.length_m (3 km by default) is not a user's road: 16 egos' slots end at 940 m, past the 1500 m
    route's end margin only when that margin is 600 m."""
    from sumo_rail.sim.starts import check_start_slots

    config = on(small_config.with_overrides({"scenario": {"length_m": 100_000.0}}), two_edges(tmp_path))
    assert network.road_length_m(config) == pytest.approx(1500.0, abs=1.0)
    check_start_slots(config, 16, network.road_length_m(config))
    tight = config.with_overrides({"env": {"end_margin_m": 600.0}})
    with pytest.raises(ValueError, match="past the road's end margin at 9"):
        check_start_slots(tight, 16, network.road_length_m(tight))


def test_a_start_window_too_near_the_routes_exit_is_refused(small_config, tmp_path):
    """The route leaves the main road at the end of main1's deceleration lane (about 1090 m); 3 lanes on main1 need
    2 x 150 m before it."""
    built = network.build(on(small_config, exit_road(tmp_path), lanes=4, route=EXIT_ROUTE,
                             flow_veh_per_h=1500.0).scenario)
    assert built.exit_at_m == pytest.approx(1090.0, abs=10.0) and built.start_lanes == 3
    assert user_network.exit_clearance_m(3) == 300.0
    docs = (Path(__file__).parents[2] / "docs" / "scenarios.md").read_text()
    assert f"at least {user_network.EXIT_PER_CHANGE_M:g} m for each lane change" in docs
    near = small_config.with_overrides({"env": {"ego_start_max_m": built.exit_at_m - 299.0}})
    with pytest.raises(ConfigError, match=r"must end at least 300 m before scenario\.route leaves the main road at "
                                          r"10\d\d m in exit\.net\.xml \(150 m for each lane change across its "
                                          r"first edge's 3 lanes, else the ego may miss the exit\); lower"):
        user_network.check_start_window(near.env, built)
    user_network.check_start_window(small_config.with_overrides(
        {"env": {"ego_start_max_m": built.exit_at_m - 300.0}}).env, built)
    straight = network.build(on(small_config, two_edges(tmp_path)).scenario)  # no exit: the window is not bound
    assert straight.exit_at_m is None
    user_network.check_start_window(small_config.with_overrides({"env": {"ego_start_max_m": 1000.0}}).env, straight)


def test_the_expert_takes_its_exit_from_the_nearest_start_the_check_lets_through(small_config, tmp_path):
    """Starts in the last 90 m of the window the check allows; 100-200 m before the exit, it missed the exit in up
    to 4 of 30 episodes."""
    config = on(small_config, exit_road(tmp_path), lanes=4, route=EXIT_ROUTE, flow_veh_per_h=1500.0,
                warmup_s=60.0, snapshots=8)
    built = network.build(config.scenario)
    high_m = built.exit_at_m - user_network.exit_clearance_m(built.start_lanes)
    config = config.with_overrides({"env": {"ego_start_min_m": high_m - 90.0, "ego_start_max_m": high_m}})
    user_network.check_start_window(config.env, built)
    assert expert_terminations(config, 40) == ["end_of_road"] * 40


def test_several_egos_start_slots_are_checked_against_the_routes_exit(small_config, tmp_path):
    """16 egos' slots of 40 m (300 m to 940 m) reach past the farthest start (about 790 m) that the exit at about
    1090 m leaves: refused; 4 egos share the window (300 m to 500 m): taken."""
    from sumo_rail.sim.starts import check_start_slots

    config = on(small_config, exit_road(tmp_path), lanes=4, route=EXIT_ROUTE, flow_veh_per_h=1500.0)
    latest_m = network.latest_start_m(config)
    assert latest_m == pytest.approx(790.0, abs=10.0) and network.latest_start_m(small_config) == float("inf")
    with pytest.raises(ValueError, match=r"16 egos need start slots of 40 m from 300 m to 940 m, past 7\d\d m, the "
                                         r"farthest start that leaves the ego room to reach its route's exit"):
        check_start_slots(config, 16, network.road_length_m(config), latest_m)
    check_start_slots(config, 4, network.road_length_m(config), latest_m)
