"""Everything else keeps working on every road (issue 35): the clients users check the project with from outside
(Gymnasium's env checker and vector envs, PettingZoo's API test, Stable-Baselines3's checker and the shared-road
VecEnv) and the bird's-eye frames, on each generated road that is not straight and on a user's netconvert network.
The outputs made from a road (demonstrations with several workers, Minari, resumed runs, videos) are tested in
tests/runners/test_every_road_outputs.py."""

from __future__ import annotations

import warnings

import gymnasium
import libsumo
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gymnasium_check_env
from gymnasium.utils.passive_env_checker import env_render_passive_checker
from pettingzoo.test import parallel_api_test
from stable_baselines3.common.env_checker import check_env as sb3_check_env
from test_scenarios import FEATURE, bend_network, road

from sumo_rail.config import Config
from sumo_rail.drivers.expert import make_expert
from sumo_rail.learning.sb3.driving_envs import driving_processes
from sumo_rail.learning.sb3.shared_road import RespawningRoad, env_seeds
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.observation import observation_space
from sumo_rail.sim.parallel_env import ParallelHighwayEnv
from sumo_rail.sim.render import BACKGROUND, EGO, ROAD, _centre

KINDS = ["merge", "merge_from_ramp", "lane_drop", "exit"]
"""Every generated road that is not straight."""


@pytest.fixture(scope="module")
def user_network(tmp_path_factory, small_config_module) -> Config:
    """A user's network built with netconvert: a bend where the road narrows from 3 lanes to 2 (as in
    test_scenarios.test_a_user_network_built_with_netconvert_is_driven_along_its_route)."""
    return bend_network(tmp_path_factory.mktemp("user_network"), small_config_module)


@pytest.fixture(params=[*KINDS, "network"])
def any_road(request, small_config) -> Config:
    """Each road that is not straight: the generated ones and a user's netconvert network."""
    if request.param == "network":
        return request.getfixturevalue("user_network")
    return road(small_config, request.param)


@pytest.mark.filterwarnings("error")  # a warning of a checker is a failure
def test_gymnasium_and_stable_baselines3_env_checkers_pass(any_road):
    env = HighwayEnv(any_road, render_mode="rgb_array")
    try:
        gymnasium_check_env(env, skip_render_check=True)  # its render check would open sumo-gui ("human")
        env_render_passive_checker(env)  # a frame of this road
        sb3_check_env(env, warn=True)
    finally:
        env.close()


def test_pettingzoo_parallel_api_test_passes(any_road):
    env = ParallelHighwayEnv(2, any_road)
    try:
        with pytest.warns(UserWarning, match="ignored unknown reset options"):  # the API test passes {"options": 1}
            parallel_api_test(env, num_cycles=200)
    finally:
        env.close()


def test_gymnasium_vector_envs_of_every_road_step_as_each_env_alone(small_config):
    """A SyncVectorEnv (one process: libsumo, then traci) and an AsyncVectorEnv (a process per env) of one env per
    road give what each env gives alone, bit for bit, across their autoresets."""
    configs = [road(small_config, kind) for kind in KINDS]
    actions = np.random.default_rng(35).integers(0, 5, size=(70, len(KINDS)))
    seeds = [11, 12, 13, 14]

    def run(envs: gymnasium.vector.VectorEnv) -> list[tuple]:
        try:
            steps = [envs.reset(seed=seeds)[0]]
            for action in actions:
                observations, rewards, terminated, truncated, _ = envs.step(action)
                steps.append((observations, rewards, terminated, truncated))
            return steps
        finally:
            envs.close()

    makers = [lambda config=config: HighwayEnv(config) for config in configs]
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*runs over traci", UserWarning)  # the second to fourth env of one process
        together = run(gymnasium.vector.SyncVectorEnv(makers))
    apart = run(gymnasium.vector.AsyncVectorEnv(makers))
    for one, other in zip(together, apart, strict=True):
        for left, right in zip(np.atleast_1d(one) if isinstance(one, np.ndarray) else one,
                               np.atleast_1d(other) if isinstance(other, np.ndarray) else other, strict=True):
            assert np.array_equal(left, right)
    ended = np.array([step[2] | step[3] for step in together[1:]])
    assert ended.any(axis=0).sum() >= 2  # episodes ended and the envs reset themselves
    for index, config in enumerate(configs):  # each env alone, with Gymnasium's next-step autoreset written out
        env = HighwayEnv(config)
        try:
            observation, _ = env.reset(seed=seeds[index])
            assert np.array_equal(observation, together[0][index])
            done = False
            for step, action in enumerate(actions[:, index], start=1):
                if done:
                    observation, _ = env.reset()
                    reward, terminated, truncated = 0.0, False, False
                else:
                    observation, reward, terminated, truncated, _ = env.step(int(action))
                done = terminated or truncated
                assert np.array_equal(observation, together[step][0][index])
                assert (reward, terminated, truncated) == (together[step][1][index], together[step][2][index],
                                                           together[step][3][index])
        finally:
            env.close()


def drive_respawning(road_: RespawningRoad | object, actions: np.ndarray) -> list[tuple]:
    """The reset's observations, then each step's (observations, rewards, dones, infos) of a RespawningRoad or a
    VecEnv of them."""
    batches = [road_.reset()]
    for action in actions:
        batches.append(road_.step(action.tolist()) if isinstance(road_, RespawningRoad) else road_.step(action))
    return batches


FIRST_EDGE = {"merge": "main_in", "merge_from_ramp": "ramp", "lane_drop": "main_in", "exit": "main_in",
              "network": "first"}
"""The first edge of the ego's route on each road: where egos start and respawn."""


def test_respawning_egos_always_drive_and_report_their_episodes_as_stable_baselines3_does(any_road):
    """Egos of a RespawningRoad (the shared-road VecEnv's process) respawn at the start of the route's first edge
    at once and their episodes end as SB3 reports them."""
    config = any_road
    space = observation_space(config)
    road_ = RespawningRoad(config, egos=2, seed=6)
    starts = []
    try:
        batches = [road_.reset()]
        for actions in np.random.default_rng(3).integers(0, 5, size=(150, 2)):
            batches.append(road_.step(actions.tolist()))
            starts += [road_.env.traffic(f"ego_{ego}").ego for ego in np.flatnonzero(batches[-1][2])]
    finally:
        road_.close()
    assert starts and all(start.lane_id.rpartition("_")[0] == FIRST_EDGE[config.scenario.kind]
                          and start.lane_position_m <= config.env.ego_start_max_m for start in starts)
    assert all(space.contains(observation) for observation in batches[0])
    ended = 0
    for observations, rewards, dones, infos in batches[1:]:
        assert observations.shape == (2, *space.shape) and rewards.dtype == np.float64 and dones.shape == (2,)
        assert all(space.contains(observation) for observation in observations)
        for ego in np.flatnonzero(dones):
            ended += 1
            assert space.contains(infos[ego]["terminal_observation"])
            # a truncation: the road's end, the time limit, or cut where the egos jam the start (no reason of its own)
            assert infos[ego]["TimeLimit.truncated"] == (infos[ego]["termination"] in ("end_of_road", "time_limit", ""))
    assert ended >= 2


@pytest.mark.parametrize("kind", ["merge_from_ramp"])
def test_the_shared_road_vec_env_is_its_roads_and_stable_baselines3_learns_on_it(small_config, tmp_path, kind):
    """The spawned VecEnv gives what its road gives in this process, and SB3's PPO collects and learns on it (a
    one-lane ramp: the road whose start the egos can jam)."""
    from stable_baselines3 import PPO

    config = road(small_config, kind)
    actions = np.random.default_rng(4).integers(0, 5, size=(60, 2))
    venv = driving_processes(config, processes=1, egos=2, seed=3, error_dir=tmp_path)
    try:
        vectorised = drive_respawning(venv, actions)
        PPO("MlpPolicy", venv, n_steps=16, batch_size=16, n_epochs=1, seed=0, device="cpu").learn(32)
    finally:
        venv.close()
    road_ = RespawningRoad(config, egos=2, seed=env_seeds(3, 1)[0])
    try:
        alone = drive_respawning(road_, actions)
    finally:
        road_.close()
    assert np.array_equal(vectorised[0], alone[0])
    for together, by_itself in zip(vectorised[1:], alone[1:], strict=True):
        assert all(np.array_equal(a, b) for a, b in zip(together[:3], by_itself[:3], strict=True))
    assert list(tmp_path.iterdir()) == []  # no process reported a failure


FEATURE_LANES = {  # SUMO's lanes of each road's feature: (lanes that must be drawn, lane places that must be grass)
    "merge": (["ramp_0", "merge_0"], []),
    "merge_from_ramp": (["ramp_0", "merge_0"], []),
    "lane_drop": (["main_in_0", "main_in_1"], ["main_in_0", "main_in_1"]),  # the closing lanes end at the zone
    "exit": (["off_ramp_0"], []),
    "network": (["second_0", "second_1"], ["first_0"]),  # the user's road past its bend; its right lane ends
}
FEATURE_AT_M = {"network": 900.0}
"""Where each road's feature is along x [m]: test_scenarios's FEATURE, or the user's network's bend."""


def distance_to_polyline(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """The distance of each point (N, 2) to a polyline (M, 2) [m]."""
    starts, ends = line[:-1], line[1:]
    along = ends - starts
    t = np.clip(np.einsum("nsk,sk->ns", points[:, None] - starts, along) / np.einsum("sk,sk->s", along, along), 0, 1)
    nearest = starts + t[..., None] * along
    return np.linalg.norm(points[:, None] - nearest, axis=2).min(axis=1)


def test_a_frame_draws_ramps_bends_and_ending_lanes_where_sumo_has_them_and_no_road_elsewhere(any_road):
    """Near the feature the frame shows road (its colour) along the lanes SUMO shapes, on the ramp, the acceleration
    lane, the lanes that end and the user's road past its bend, and none where SUMO has no lane: beside the work zone,
    off the ramps, beside the bend."""
    kind = any_road.scenario.kind
    env = HighwayEnv(any_road)
    expert = make_expert("normal", env.config.env.speed_step_mps, env.config.expert.view_range_m)
    try:
        observation, _ = env.reset(seed=1)
        while env.traffic.ego.front_x < FEATURE_AT_M.get(kind, FEATURE["feature_at_m"]) + 10.0:
            observation, _, terminated, truncated, _ = env.step(expert(observation, env.traffic))
            assert not (terminated or truncated)
        frame = env.frame()
        shapes = {lane: np.array(libsumo.lane.getShape(lane)) for lane in libsumo.lane.getIDList()}
        widths = {lane: libsumo.lane.getWidth(lane) for lane in shapes}
    finally:
        env.close()
    ego_rows, ego_columns = np.nonzero((frame == EGO).all(axis=2))
    ego_px = np.array([ego_columns.mean(), ego_rows.mean()])  # the ego's centre, the frame's fixed point
    ego = env.traffic.ego
    ego_centre = _centre(np.array([ego.front_x, ego.front_y]), ego.heading_rad, ego.length_m)

    def colours(points: np.ndarray) -> np.ndarray:
        """The frame's colour at world points [m] (north up, 5 px a metre), only those inside the frame."""
        pixels = np.rint(ego_px + (points - ego_centre) * np.array([5.0, -5.0])).astype(int)
        inside = (pixels[:, 0] >= 0) & (pixels[:, 0] < frame.shape[1]) & (pixels[:, 1] >= 40) & (
            pixels[:, 1] < frame.shape[0])
        return frame[pixels[inside, 1], pixels[inside, 0]]

    def along(lane: str, step_m: float = 2.0) -> np.ndarray:
        """Points of the lane every `step_m`, 1 m either side of its centre line (where the ego's forward beam runs)."""
        line = shapes[lane]
        lengths = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(line, axis=0), axis=1))]
        at = np.arange(0.0, lengths[-1], step_m)
        segment = np.clip(np.searchsorted(lengths, at, side="right") - 1, 0, len(line) - 2)
        direction = (line[segment + 1] - line[segment]) / np.diff(lengths)[segment, None]
        centre = np.stack([np.interp(at, lengths, line[:, 0]), np.interp(at, lengths, line[:, 1])], axis=1)
        side = np.stack([-direction[:, 1], direction[:, 0]], axis=1)
        return np.concatenate([centre + side, centre - side])

    drawn, ended = FEATURE_LANES[kind]
    for lane in drawn:
        seen = colours(along(lane))
        assert len(seen) > 20, lane  # the lane is in view
        assert (seen == ROAD).all(axis=1).mean() > 0.7, lane  # road, but where a vehicle, a beam or a line is
    for lane in ended:  # where the lane would go on, 20 m to 100 m past its end (beside the work zone): grass
        end, before = shapes[lane][-1], shapes[lane][-2]
        heading = (end - before) / np.linalg.norm(end - before)
        beyond = end + np.arange(20.0, 100.0)[:, None] * heading
        across = np.array([-heading[1], heading[0]])
        seen = colours(np.concatenate([beyond + across, beyond - across]))
        assert len(seen) > 100 and not (seen == ROAD).all(axis=1).any(), lane
    xs, ys = np.meshgrid(np.arange(-115.0, 115.0, 1.5), np.arange(-40.0, 40.0, 1.5))
    grid = ego_centre + np.stack([xs.ravel(), ys.ravel()], axis=1)
    off_road = np.all([distance_to_polyline(grid, line) > widths[lane] / 2 + 1.0
                       for lane, line in shapes.items()], axis=0)
    on_road = np.any([distance_to_polyline(grid, line) < widths[lane] / 2 - 0.5
                      for lane, line in shapes.items()], axis=0)
    off, on = colours(grid[off_road]), colours(grid[on_road])
    assert len(off) > 1000 and not (off == ROAD).all(axis=1).any()  # no road where SUMO has none
    assert (off == BACKGROUND).all(axis=1).mean() > 0.9  # grass (but where a beam crosses it)
    assert (on == ROAD).all(axis=1).mean() > 0.8
