"""Watching episodes: observers see every SUMO step, or each reset and decision, with every vehicle as rows; they
change nothing, and stop with their block. Who drives the egos: the env core's controllers."""

from __future__ import annotations

import numpy as np
import pytest

from sumo_rail.sim.actions import Action
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.observers import ROW_FIELDS, Decision, Moment, VehicleCapture
from sumo_rail.sim.simulation import EGO_ID, SimulationError

ACTIONS = [Action.ACCELERATE, Action.LANE_LEFT, Action.KEEP, Action.DECELERATE, Action.KEEP, Action.LANE_RIGHT]


@pytest.fixture(scope="module")
def env(small_config_module):
    environment = HighwayEnv(small_config_module)
    yield environment
    environment.close()


def episode(env: HighwayEnv) -> tuple[np.ndarray, list[dict]]:
    """Observations and infos of seed 5 under `ACTIONS`."""
    observation, info = env.reset(seed=5)
    observations, infos = [observation], [info]
    for action in ACTIONS:
        observation, _, _, _, info = env.step(int(action))
        observations.append(observation)
        infos.append(info)
    return np.array(observations), infos


class Moments:
    """A reset-and-decision observer keeping what it is shown."""

    every_step = False

    def __init__(self) -> None:
        self.seen: list[tuple[str, float, dict, dict, dict]] = []
        self.decisions: list[Decision] = []

    def __call__(self, moment: Moment) -> None:
        self.seen.append((moment.kind, moment.time_s, dict(moment.actions), dict(moment.infos), moment.vehicles()))
        self.decisions += moment.decisions()


class EveryVehicle:
    """An every-step observer counting the moments whose rows are not SUMO's vehicles, all of them."""

    every_step = True

    def __init__(self, env: HighwayEnv) -> None:
        self.env, self.wrong = env, 0

    def __call__(self, moment: Moment) -> None:
        self.wrong += sorted(moment.vehicles()["vehicle_id"]) != sorted(self.env.simulation._api.vehicle.getIDList())


def test_an_every_step_observer_sees_each_step_of_the_periods_and_changes_nothing(env):
    plain, _ = episode(env)
    with env.watching(VehicleCapture(every_step=True)) as capture, env.watching(EveryVehicle(env)) as check:
        watched, _ = episode(env)
    assert check.wrong == 0  # vehicles that enter in the episode are read from their first step on
    np.testing.assert_array_equal(plain, watched)  # the rows' subscriptions leave the episode as it was
    steps = env.config.env.steps_per_decision(env.config.scenario.step_length_s)
    assert capture.moments == len(ACTIONS) * steps
    times = np.unique(capture.columns["time_s"])
    np.testing.assert_allclose(np.diff(times), env.config.scenario.step_length_s)
    assert times[-1] == pytest.approx(env.simulation.time_s)
    assert set(capture.columns) == {"frame", "time_s", *ROW_FIELDS}
    last = [k for k, frame in enumerate(capture.columns["frame"]) if frame == capture.moments - 1]
    ego = last[[capture.columns["vehicle_id"][k] for k in last].index(EGO_ID)]
    assert (capture.columns["x_m"][ego], capture.columns["y_m"][ego]) == pytest.approx(
        (env.traffic.ego.front_x, env.traffic.ego.front_y))
    assert capture.columns["speed_mps"][ego] == pytest.approx(env.traffic.ego.speed_mps)
    assert set(env.traffic.neighbours.ids) < {capture.columns["vehicle_id"][k] for k in last}  # every vehicle


def test_a_decision_observer_sees_the_reset_and_each_decision_with_its_actions_and_infos(env):
    """... and at each decision what the ego decided on: the observation and traffic view before the period."""
    with env.watching(Moments()) as moments:
        observations, infos = episode(env)
    assert [(decision.agent, decision.action, decision.info) for decision in moments.decisions] == [
        (EGO_ID, int(action), info) for action, info in zip(ACTIONS, infos[1:], strict=True)]
    np.testing.assert_array_equal([decision.observation for decision in moments.decisions], observations[:-1])
    assert [decision.traffic.ego.lane_position_m for decision in moments.decisions] == pytest.approx(
        [info["position_m"] for info in infos[:-1]])
    assert [kind for kind, *_ in moments.seen] == ["reset"] + ["decision"] * len(ACTIONS)
    assert [actions for _, _, actions, _, _ in moments.seen] == [{}] + [{EGO_ID: int(a)} for a in ACTIONS]
    assert [shown[EGO_ID] for _, _, _, shown, _ in moments.seen] == infos
    for _, _, _, shown, rows in moments.seen:
        ego = rows["vehicle_id"].index(EGO_ID)
        assert rows["lane_position_m"][ego] == pytest.approx(shown[EGO_ID]["position_m"])
    np.testing.assert_allclose(np.diff([time_s for _, time_s, *_ in moments.seen]),
                               env.config.env.decision_period_s)


def test_an_observer_stops_with_its_block(env):
    """... also one that came before the simulation (the env's next reset starts one)."""
    env.close()
    steps, decisions = VehicleCapture(every_step=True), Moments()
    with env.watching(steps), env.watching(decisions):
        env.reset(seed=1)
        env.step(int(Action.KEEP))
    seen = (steps.moments, len(decisions.seen))
    env.step(int(Action.KEEP))
    env.reset(seed=2)
    assert seen == (steps.moments, len(decisions.seen)) and seen[0] > 0 and seen[1] == 2


def test_who_drives_is_a_controller_of_a_known_name(env):
    with pytest.raises(ValueError, match=r"'controller' must be one of 'actions', 'sumo' or a controller \(or a "
                                         r"mapping of agents to them\), got 'idm'"):
        env.reset(seed=0, options={"controller": "idm"})
    with pytest.raises(ValueError, match="'controller' names no agent 'ego_1'; agents are ego"):
        env.reset(seed=0, options={"controller": {"ego_1": "sumo"}})
    with pytest.raises(SimulationError, match="SUMO's own driver needs vehicle type scene_idm"):
        env.reset(seed=0, options={"controller": "sumo"})  # the generated roads' routes do not bring it


def test_the_simulation_refuses_an_observer_of_decisions(env):
    """Simulation.watching shows every SUMO step; an observer of decisions belongs to the env, which says so."""
    env.reset(seed=1)
    with pytest.raises(ValueError, match="Moments watches decisions, not SUMO steps"):
        env.simulation.watch(Moments())
    with env.simulation.watching(VehicleCapture(every_step=True)) as capture:
        env.step(int(Action.KEEP))
    assert capture.moments > 0
