"""Scenes on any SUMO network: FCD of SUMO's own drivers on a user's network of several edges (an on-ramp joining as
an acceleration lane that then ends, a bend) imports, reads as demonstrations, trains and evaluates with the
documented commands; a seat's observation (route block included) is the one the scene gives; lane changes are read
across edges in the route frame."""

from __future__ import annotations

import subprocess

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from sumo_rail_cli.main import cli

from sumo_rail.config import Config
from sumo_rail.datasets import read_metadata
from sumo_rail.drivers.policies import Policy, PolicyShape
from sumo_rail.evaluation.scene_evaluation import calibrated_idm_driver
from sumo_rail.learning.log_dagger import LogDaggerTask, LogSeats
from sumo_rail.recordings.actions import ActionRule, read_track
from sumo_rail.recordings.idm_calibration import CalibrationSettings, windows_of
from sumo_rail.recordings.idm_windows import scene_rows
from sumo_rail.recordings.scene import read_scene
from sumo_rail.recordings.scene_drivers import reactive_types
from sumo_rail.recordings.scene_observations import in_route_frame, observe, scene_road, scene_routes
from sumo_rail.recordings.seat import SceneEnv
from sumo_rail.recordings.seats import choose_seats
from sumo_rail.runners.backends import SerialBackend
from sumo_rail.sim.actions import Action, split_acceleration_action
from sumo_rail.sim.network import netconvert, sumo_binary
from sumo_rail.sim.observation import observation_names, observation_space

SPEED = ("--set", "scenario.lanes=3", "--set", "scenario.speed_limit_mps=30", "--set", "env.v_max_mps=30")
CONFIG = Config.from_dict({"scenario": {"lanes": 3, "speed_limit_mps": 30.0}, "env": {"v_max_mps": 30.0},
                           "observation": {"lane_block": 1, "route_block": 1}})


def ramp_network(folder):
    """Main road "in" (2 lanes) -> "mid" (3 lanes: the on-ramp "ramp" joins as its rightmost lane, which ends there)
    -> "out" (2 lanes, bending left), 30 m/s, built by netconvert from plain XML."""
    (folder / "road.nod.xml").write_text(
        '<nodes><node id="a" x="0" y="0"/><node id="r" x="200" y="-60"/><node id="b" x="500" y="0"/>'
        '<node id="c" x="900" y="0"/><node id="d" x="1400" y="150"/></nodes>')
    (folder / "road.edg.xml").write_text(
        '<edges><edge id="in" from="a" to="b" numLanes="2" speed="30"/>'
        '<edge id="ramp" from="r" to="b" numLanes="1" speed="30"/>'
        '<edge id="mid" from="b" to="c" numLanes="3" speed="30"/>'
        '<edge id="out" from="c" to="d" numLanes="2" speed="30" shape="900,0 1100,10 1250,60 1400,150"/></edges>')
    netconvert({"nodes": folder / "road.nod.xml", "edges": folder / "road.edg.xml"}, folder / "road.net.xml")
    return folder / "road.net.xml"


@pytest.fixture(scope="module")
def network_scene(tmp_path_factory):
    """80 s of SUMO's drivers (cars and trucks on the main road, cars from the ramp) as FCD, imported."""
    folder = tmp_path_factory.mktemp("network_scene")
    net = ramp_network(folder)
    (folder / "traffic.rou.xml").write_text(
        '<routes><vType id="car" length="4.5" vClass="passenger"/>'
        '<vType id="truck" length="12" width="2.5" vClass="truck" maxSpeed="25"/>'
        '<flow id="main" type="car" from="in" to="out" begin="0" end="70" vehsPerHour="1800" departLane="random" '
        'departSpeed="max"/><flow id="lorry" type="truck" from="in" to="out" begin="0" end="70" vehsPerHour="200" '
        'departLane="0" departSpeed="max"/><flow id="onramp" type="car" from="ramp" to="out" begin="0" end="70" '
        'vehsPerHour="600" departSpeed="max"/></routes>')
    subprocess.run([sumo_binary("sumo"), "-n", str(net), "-r", str(folder / "traffic.rou.xml"), "--step-length",
                    "0.1", "--end", "80", "--seed", "1", "--fcd-output", str(folder / "fcd.xml"),
                    "--fcd-output.acceleration", "--no-step-log", "--no-warnings"], check=True, capture_output=True)
    result = CliRunner().invoke(cli, ["import-recording", "--format", "fcd", str(folder / "fcd.xml"), "--network",
                                      str(net), "--out", str(folder / "scene")])
    assert result.exit_code == 0, result.output
    return folder / "scene"


def test_fcd_on_a_users_network_reads_trains_and_evaluates_with_the_documented_commands(network_scene, tmp_path):
    demos = tmp_path / "demos.parquet"
    result = CliRunner().invoke(cli, ["recorded-demos", str(network_scene), "--preset", "recommended", *SPEED,
                                      "--out", str(demos)])
    assert result.exit_code == 0, result.output
    table = pq.read_table(demos).to_pandas()
    ramp = table["episode"].isin([k for k, vehicle in enumerate(sorted(
        read_scene(network_scene).split.query("split == 'train'")["vehicle_id"])) if vehicle.startswith("onramp")])
    assert ramp.any() and (table.loc[ramp, "action"] == Action.LANE_LEFT).any()  # the ramp's cars merge left
    forward = table.groupby("episode")["position_m"].apply(lambda along: bool(np.all(np.diff(along) > 0)))
    assert forward.all()  # positions along each car's route, across edges (an edge's lane position starts at 0)
    result = CliRunner().invoke(cli, ["train", "--preset", "recommended", *SPEED, "--demos", str(demos),
                                      "--iterations", "1", "--set", "rail.directions=2", "--set", "rail.top=1",
                                      "--set", "bc.epochs=1", "--eval-every", "0", "--set", "scenario.length_m=1500",
                                      "--set", "scenario.warmup_s=60", "--set", "scenario.snapshots=2",
                                      "--set", "env.ego_start_max_m=300", "--out", str(tmp_path / "run")])
    assert result.exit_code == 0, result.output
    out = tmp_path / "seats.parquet"
    result = CliRunner().invoke(cli, ["evaluate-scene", str(network_scene), "--preset", "recommended", *SPEED,
                                      "--policy", str(tmp_path / "run" / "policy_latest.npz"), "--policy",
                                      "sumo-idm", "--mode", "non-reactive", "--mode", "reactive", "--seats", "3",
                                      "--horizon-s", "10", "--out", str(out)])
    assert result.exit_code == 0, result.output
    episodes = pd.read_parquet(out)
    assert len(episodes) == 12 and episodes["progress_ratio"].between(0.5, 1.5).all(), episodes["progress_ratio"]


def test_the_seat_sees_what_the_scene_gives_on_the_ramp_the_bend_and_across_edges(network_scene):
    """The seated ego's first observation (its lanes and positions in its own route's frame, the route block, the
    road's edges and junctions for the LIDAR) is the scene's observation of the recorded vehicle there, on an edge or
    in a junction."""
    env = SceneEnv(CONFIG, network_scene)
    tracks, names = env.scene.tracks, observation_names(CONFIG)
    routes = scene_routes(tracks)
    seats = [("onramp.3", "ramp"), ("onramp.3", "mid"), ("main.5", "out"), ("lorry.1", "in"), ("main.5", ":c_0")]
    for vehicle, edge in seats:
        rows = tracks[(tracks["vehicle_id"] == vehicle) & (tracks["edge"] == edge)]
        start_s = round(float(rows["time_s"].iloc[len(rows) // 2]), 6)
        observation, _ = env.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
        snapshot = env.frames.at(start_s)
        scene = observe(CONFIG, env.road, *snapshot, vehicle, float(env.traffic.ego.speed_mps), routes[vehicle])
        set_point = names.index("cruise_set_point")
        assert np.delete(observation, set_point) == pytest.approx(np.delete(scene, set_point), abs=1e-3), (vehicle,
                                                                                                          edge)
        assert env.traffic.ego.lane_id.startswith(edge)
    env.close()


def test_lane_changes_are_read_across_edges_in_the_route_frame(tmp_path):
    """in_0 continues as mid_1 (the ramp's lane is added on the right) and mid_1 as out_0 (it ends on the right):
    no lane change; in_0 then mid_2 is a change to the left made at the edges' boundary."""
    road = scene_road(ramp_network(tmp_path))
    rule = ActionRule.for_env(CONFIG.env)
    time_s = np.round(np.arange(0.0, 6.0, 0.1), 6)

    def actions(lanes: list[tuple[str, int]], positions: np.ndarray) -> np.ndarray:
        track = pd.DataFrame({"time_s": time_s, "edge": [edge for edge, _ in lanes],
                              "lane": [lane for _, lane in lanes], "lane_position_m": positions})
        framed = in_route_frame(road, track, ("in", "mid", "out"))
        return read_track(time_s, np.full(len(time_s), 25.0), framed["lane"].to_numpy(), framed["edge"].to_numpy(),
                          None, rule)[1]

    along = 25.0 * time_s
    kept = [("in", 0)] * 20 + [("mid", 1)] * 20 + [("out", 0)] * 20
    assert (actions(kept, along) == Action.KEEP).all()
    changed = [("in", 0)] * 30 + [("mid", 2)] * 30
    assert list(actions(changed, along)).count(Action.LANE_LEFT) == 1


def test_a_trucks_seat_is_taken_on_request_and_the_ego_is_then_a_truck_of_its_size(network_scene):
    scene = read_scene(network_scene)
    trucks = choose_seats(scene, "train", 10.0, 2.0, None, 0, classes=("truck",))
    assert trucks and all(seat.vehicle.startswith("lorry") for seat in trucks)
    assert not any(seat.vehicle.startswith("lorry") for seat in choose_seats(scene, "train", 10.0, 2.0, None, 0))
    env = SceneEnv(CONFIG, network_scene)
    env.reset(seed=0, options={"vehicle": trucks[0].vehicle, "start_s": trucks[0].start_s})
    ego = env.traffic.ego
    assert (ego.length_m, ego.width_m) == pytest.approx((12.0, 2.5))  # the package's truck type, which FCD names
    assert env.simulation._api.vehicle.getVehicleClass("ego") == "truck"
    env.reset(seed=0, options={"vehicle": "main.5"})  # a car's seat after it: a car again
    assert env.simulation._api.vehicle.getVehicleClass("ego") == "passenger"
    env.close()



def test_a_trucks_seat_driven_by_sumo_stays_a_truck_of_its_size(network_scene):
    """sumo-idm (and sumo-idm-calibrated) in a truck's seat: SUMO's driver type is a car's, the ego keeps its class."""
    truck = choose_seats(read_scene(network_scene), "train", 10.0, 2.0, None, 0, classes=("truck",))[0]
    env = SceneEnv(CONFIG, network_scene)
    env.reset(seed=0, options={"vehicle": truck.vehicle, "start_s": truck.start_s, "controller": "sumo"})
    vehicle = env.simulation._api.vehicle
    assert (vehicle.getVehicleClass("ego"), vehicle.getLength("ego"), vehicle.getWidth("ego")) == ("truck", 12.0, 2.5)
    env.close()


def test_the_calibrated_idm_in_a_trucks_seat_is_fitted_on_the_trains_trucks(network_scene):
    """sumo-idm-calibrated with --seat-class truck: a truck's seat gets the IDM fitted on the train split's trucks and
    a desired speed of its own (the cars' median desired speed, 32 m/s, raised it above the trucks' 25 m/s)."""
    scene = read_scene(network_scene)
    seats = choose_seats(scene, "validation", 10.0, 2.0, None, 0, classes=("truck",))
    driver, calibrations = calibrated_idm_driver([scene], 0.1, 2.0, 10.0, seats)
    assert [found.settings.vehicle_class for found in calibrations.values()] == ["truck"]
    controller, _ = driver.seat_controller(scene, seats[0], 0.1)
    trucks = scene.tracks[scene.tracks["vehicle_class"] == "truck"]
    assert controller.desired_mps <= trucks["speed_mps"].max() + 0.5


def test_reactive_trucks_driven_by_the_calibrated_idm_stay_trucks(network_scene):
    """The reactive mode drives the recording's trucks by the IDM calibrated on the train split as trucks (they were
    passenger cars of a truck's size)."""
    scene = read_scene(network_scene)
    env = SceneEnv(CONFIG, network_scene, reactive=True, types=reactive_types(scene, 0.1).types)
    env.reset(seed=0, options={"vehicle": "main.5"})
    env.step(env.action_space.sample())
    vehicle = env.simulation._api.vehicle
    classes = {other: vehicle.getVehicleClass(other) for other in vehicle.getIDList() if other != "ego"}
    env.close()
    assert any(other.startswith("lorry") for other in classes)
    assert all((kind == "truck") == other.startswith("lorry") for other, kind in classes.items()), classes

def test_record_sumo_drivers_on_a_users_network_flows_from_every_entry_and_reads_as_demonstrations(tmp_path):
    """record-sumo-drivers with scenario.kind network: the drivers enter from the road's start and the on-ramp, the
    scene names the user's network (with its sha256), and recorded-demos reads it."""
    net = ramp_network(tmp_path)
    on_network = ["--set", "scenario.kind=network", "--set", f"scenario.network={net}", "--set",
                  "scenario.route=in mid out", "--set", "scenario.warmup_s=40", "--set", "scenario.flow_veh_per_h=1500",
                  "--set", "scenario.lanes=3"]
    result = CliRunner().invoke(cli, ["record-sumo-drivers", "--out", str(tmp_path / "scene"), "--seed", "2",
                                      "--duration-s", "30", *on_network])
    assert result.exit_code == 0, result.output
    scene = read_scene(tmp_path / "scene")
    assert scene.network == net.resolve() and str(net.resolve()) in scene.meta.sources
    firsts = scene.tracks.sort_values("time_s").groupby("vehicle_id")["edge"].first()
    entered = scene.tracks[scene.tracks["vehicle_id"].isin(firsts.index[firsts == "ramp"])]
    assert len(entered) and (entered["edge"] == "mid").any()  # some came in by the ramp and joined the main road
    result = CliRunner().invoke(cli, ["recorded-demos", str(tmp_path / "scene"), *SPEED, "--out",
                                      str(tmp_path / "demos.parquet")])
    assert result.exit_code == 0, result.output


def test_the_teacher_on_a_network_scene_reads_the_human_in_the_seats_route_frame(network_scene, tmp_path):
    """A car seated on the on-ramp that joins the main road within its seat: the teacher driving (beta 1) keeps the
    ego on the human's track across the edges, so its labels stay near the human's read accelerations (the human read
    per edge was 270 m behind the ego once on the next edge: full braking)."""
    demos = tmp_path / "demos.parquet"
    result = CliRunner().invoke(cli, ["recorded-demos", str(network_scene), *SPEED, "--set",
                                      "actions.interface=acceleration", "--out", str(demos)])
    assert result.exit_code == 0, result.output
    config = Config.from_dict({"actions": {"interface": "acceleration"}, "scenario": {"lanes": 3,
                              "speed_limit_mps": 30.0}, "env": {"v_max_mps": 30.0}})
    seats = LogSeats.of(read_metadata(demos), str(demos), config, 7.0, 8.0, 3.0)
    tracks = read_scene(network_scene).tracks
    crossing = [k for k, seat in enumerate(seats.seats) if set(tracks[(tracks["vehicle_id"] == seat.vehicle) & (
        tracks["time_s"].between(seat.start_s, seat.start_s + 4.0))]["edge"]) >= {"ramp", "mid"}]
    assert crossing
    k = crossing[0]
    shape = PolicyShape("linear", observation_space(config).shape[0], 0, 3 * config.actions.acceleration_bins)
    policy = Policy(shape, np.zeros(shape.parameter_count, np.float32))  # never asked: the teacher drives
    with SerialBackend() as backend:
        episode, = backend.run([LogDaggerTask(seats.config, policy, seats.seats[k], seats.humans[k], 3.0, 1.0, 7)])
    actions = config.actions
    labelled = [actions.acceleration_mps2(split_acceleration_action(int(a), actions)[0]) for a in episode.labels]
    human = seats.humans[k].accelerations_mps2
    first = round((seats.seats[k].start_s - seats.humans[k].instants_s[0]) / seats.humans[k].period_s)
    assert len(labelled) >= 14
    assert np.abs(np.array(labelled) - human[first:first + len(labelled)]).max() < 1.0, labelled


def test_the_idm_calibration_finds_a_leader_on_the_next_edge_of_the_followers_route(tmp_path):
    """The follower on "in" and its leader already on "mid" (the lane it continues into, past the junction): the
    leader is found along the follower's route with the gap along it (the rest of "in", the junction's lane, the
    leader's lane position less its length), at every step, and a window follows it across the edges; it was missed
    (only the same edge and lane were searched) and the follower read as free."""
    road = scene_road(ramp_network(tmp_path))
    lane = road.net.lane
    (via,) = [link[4] for link in lane.getLinks("in_0") if link[0] == "mid_1"]
    ends = np.cumsum([lane.getLength("in_0"), lane.getLength(via)])
    rows = []
    for k in range(31):  # 3 s at 10 m/s: the follower crosses the junction, the leader drives on "mid"
        along = 450.0 + k  # the follower's front along its route [m]
        place = (("in", 0, along) if along < ends[0] else (via.rsplit("_", 1)[0], 0, along - ends[0])
                 if along < ends[1] else ("mid", 1, along - ends[1]))
        for vehicle, (edge, index, position) in (("F", place), ("L", ("mid", 1, 10.0 + k))):
            rows.append({"vehicle_id": vehicle, "time_s": round(k * 0.1, 9), "speed_mps": 10.0, "edge": edge,
                         "lane": index, "lane_position_m": position, "length_m": 4.5})
    scene = scene_rows(pd.DataFrame(rows), road, 0.1)
    follower = scene.vehicle == "F"
    assert (scene.leader[follower] >= 0).all() and (scene.vehicle[scene.leader[follower]] == "L").all()
    expected = ends[1] + 10.0 - 4.5 - 450.0
    np.testing.assert_allclose(scene.gap_m[follower], expected, atol=1e-9)
    windows = windows_of(scene, {"F"}, 0.1, CalibrationSettings())
    assert len(windows) == 3 and windows.gap_m == pytest.approx([expected] * 3)
    np.testing.assert_allclose(windows.recorded_travel_m, 20.0, atol=1e-9)
