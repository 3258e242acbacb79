import dataclasses

import libsumo
import numpy as np
import pytest

from sumo_rail.sim.simulation import EGO_ID, WARM_STATE_POOLS, Simulation, SimulationError


@pytest.fixture
def sim(small_config):
    simulation = Simulation(small_config.scenario, context_radius_m=120.0)
    yield simulation
    simulation.close()


def traffic_after(sim: Simulation, warm_state: int, seed: int, seconds: float = 20.0) -> dict[str, tuple]:
    sim.reset(warm_state=warm_state, sumo_seed=seed, ego_lane=2, ego_position_m=400.0)
    sim.advance_egos(round(seconds / sim.scenario.step_length_s), [EGO_ID])
    return {v: libsumo.vehicle.getPosition(v) for v in libsumo.vehicle.getIDList()}


def test_same_seed_same_traffic_and_different_seeds_differ(sim):
    first = traffic_after(sim, 0, seed=11)
    other = traffic_after(sim, 0, seed=12)
    again = traffic_after(sim, 0, seed=11)
    assert first == again
    assert first != other
    assert len(first) > 20  # the ego starts among warm, flowing traffic


def test_warm_states_differ_from_each_other(sim):
    assert traffic_after(sim, 0, seed=1, seconds=0.1) != traffic_after(sim, 1, seed=1, seconds=0.1)


def test_second_simulation_in_one_process_is_refused(sim, small_config):
    with pytest.raises(SimulationError, match="one simulation per process"):
        Simulation(small_config.scenario, context_radius_m=120.0)


def test_close_twice_is_harmless_and_a_new_simulation_can_start(small_config):
    first = Simulation(small_config.scenario, context_radius_m=120.0)
    first.close()
    first.close()
    with pytest.raises(SimulationError, match="closed"):
        first.reset(0, 1, 0, 400.0)
    second = Simulation(small_config.scenario, context_radius_m=120.0)
    second.close()


def test_observe_returns_neighbours_without_the_ego(sim):
    sim.reset(warm_state=0, sumo_seed=3, ego_lane=1, ego_position_m=400.0)
    ego, neighbours = sim.observe()
    assert EGO_ID not in neighbours.ids
    assert ego.lane == 1 and ego.lane_position_m == pytest.approx(400.0, abs=5.0)
    assert neighbours.front_xy.shape == (len(neighbours.ids), 2)
    distances = np.hypot(*(neighbours.front_xy - [ego.front_x, ego.front_y]).T)
    assert np.all(distances <= 120.0 + 1e-6)


def test_forced_rear_end_collision_is_reported(sim):
    sim.reset(warm_state=0, sumo_seed=5, ego_lane=0, ego_position_m=400.0)
    libsumo.vehicle.add("blocker", "highway_route", typeID="truck", depart="now", departLane="0",
                        departPos="460", departSpeed="0")
    libsumo.vehicle.setSpeedMode(EGO_ID, 0)
    libsumo.vehicle.setSpeed(EGO_ID, 50.0)
    for _ in range(20):
        report, = sim.advance_egos(5, [EGO_ID])
        if report.ego_collided:
            break
    assert report.ego_collided and not report.ego_left_network
    assert EGO_ID not in libsumo.vehicle.getIDList()


def test_a_period_report_reads_watched_vehicles_until_the_collision_that_ends_the_ego(sim):
    """Period after period with two watched vehicles, up to the collision that ends the ego's episode: the report says
    when the ego went, and the watched vehicles' lowest accelerations (the blocker's once SUMO has inserted it: while
    it waits, SUMO answers its invalid value, -1073741824, which is no acceleration)."""
    sim.reset(warm_state=0, sumo_seed=5, ego_lane=0, ego_position_m=400.0)
    libsumo.vehicle.add("blocker", "highway_route", typeID="truck", depart="now", departLane="0", departPos="460",
                        departSpeed="0")
    libsumo.vehicle.setSpeedMode(EGO_ID, 0)
    libsumo.vehicle.setSpeed(EGO_ID, 50.0)
    watch = [next(vehicle for vehicle in libsumo.vehicle.getIDList() if vehicle != EGO_ID), "blocker"]
    reports = []
    while not (reports and reports[-1].ego_collided) and len(reports) < 20:
        reports.extend(sim.advance_egos(5, [EGO_ID], watch))
    assert reports[-1].ego_collided and reports[-1].left_at_s is not None
    assert all(report.left_at_s is None for report in reports[:-1])
    assert set(reports[-1].watched_min_acceleration_mps2) == set(watch)
    lowest = [value for report in reports for value in report.watched_min_acceleration_mps2.values()]
    assert min(lowest) > -20.0  # real decelerations only


def test_road_edges_bound_all_lanes(sim):
    edges = sim.road_edges()
    ys = sorted({round(y, 3) for y in edges[:, :, 1].ravel()})
    assert ys == [pytest.approx(-5 * 3.2), pytest.approx(0.0)]


def vehicles_of_state(path) -> set[str]:
    return {line.split('id="')[1].split('"')[0] for line in path.read_text().splitlines() if "<vehicle " in line}


def test_warm_state_pools_never_share_a_state(sim):
    pools = {pool: sim._pool(pool) for pool in WARM_STATE_POOLS}
    paths = [path for states in pools.values() for path in states]
    assert len(set(paths)) == len(paths) == 3 * sim.warm_state_count
    contents = {path.read_bytes() for path in paths}
    assert len(contents) == len(paths)  # every state distinct, across pools too
    train, test = pools["train"][0], pools["test"][0]
    positions = [traffic_after(sim, 0, seed=1, seconds=0.1)]
    sim.reset(warm_state=0, sumo_seed=1, ego_lane=2, ego_position_m=400.0, pool="test")
    positions.append({v: libsumo.vehicle.getPosition(v) for v in libsumo.vehicle.getIDList()})
    assert positions[0] != positions[1]
    assert vehicles_of_state(train) and vehicles_of_state(test)
    with pytest.raises(ValueError, match="warm-state pool"):
        sim.reset(warm_state=0, sumo_seed=1, ego_lane=2, ego_position_m=400.0, pool="holdout")


def test_an_ego_with_no_room_to_enter_is_an_error_naming_the_traffic_flow(small_config, monkeypatch):
    jammed = dataclasses.replace(small_config.scenario, flow_veh_per_h=14000.0)
    # traffic queues to enter the road, and no place is safe: SUMO never inserts the ego, nor may it be placed
    monkeypatch.setattr(Simulation, "_safe_speed", lambda self, lane, position_m, max_speed_mps: None)
    simulation = Simulation(jammed, context_radius_m=120.0)
    try:
        with pytest.raises(SimulationError, match=r"could not enter lane 2 .*scenario\.flow_veh_per_h is 14000 veh/h"):
            simulation.reset(warm_state=0, sumo_seed=1, ego_lane=2, ego_position_m=400.0)
    finally:
        simulation.close()


def test_the_traci_client_catches_what_its_connection_raises_after_libsumo_was_loaded():
    """With libsumo loaded (LIBSUMO_AS_TRACI), traci's own names are libsumo's while its socket connection raises
    its own exceptions: the client's must be the connection's, or a collision over the traci fallback is a crash."""
    import traci.connection

    from sumo_rail.sim.sumo_api import load_api

    load_api("libsumo")
    client = load_api("traci")
    assert client.TraCIException is traci.connection.TraCIException
    assert client.FatalTraCIError is traci.connection.FatalTraCIError
    assert callable(client.start) and callable(client.getConnection)
