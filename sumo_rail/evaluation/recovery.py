"""The recovery test: episodes that start the ego off the expert's behaviour, and how many decisions a driver takes
to return to it (and whether it does).

An episode starts on a held-out seed as any evaluation episode; a scripted start then takes the ego off the
expert's behaviour, and once there, the driver drives. Start conditions (`CONDITIONS`):
- "low": the cruise set-point brought into the expert's band (desired speed +- half a speed step), then
  `LOW_STEPS` steps down (6 m/s by default); recovered once the set-point is back within the band;
- "high": the set-point brought into the band, then raised to `env.v_max_mps` (2.8 m/s above the normal expert's
  desired speed); recovered as "low";
- "left": the ego moved left (one lane at least, lane after lane while the set-point is in the band), until it is
  in a lane the expert would leave: the expert would move right (the lane to its right is free for its keep-right
  time); recovered once the expert would no longer move right (the ego is moving right, or traffic there makes the
  expert wait).
A start not reached within `START_LIMIT` decisions (lane changes wait for a safe gap) leaves the episode out. The
driver then has `horizon` decisions; a driver not recovered by then is censored (an episode that ends first, at the
end of the road or in a collision, says so and is left out too).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from sumo_rail.config import Config
from sumo_rail.drivers.expert import STYLES, make_expert
from sumo_rail.runners.backends import WorkerContext
from sumo_rail.runners.rollout import DriverSpec, ExpertDriver
from sumo_rail.sim.actions import Action
from sumo_rail.sim.traffic import TrafficView

CONDITIONS = ("low", "high", "left")
LOW_STEPS = 3
"""Speed steps the "low" start takes the set-point down from the expert's band."""
START_LIMIT = 60
"""Decisions the scripted start may take to reach its condition."""
HORIZON = 60
"""Decisions the driver is given to recover (30 s at 0.5 s a decision; with the start limit, an episode from the
farthest start position keeps clear of the end of the default road)."""


def in_band(set_point_mps: float, desired_mps: float, speed_step_mps: float) -> bool:
    """The set-point is where the expert leaves it: within half a speed step of its desired speed [m/s]."""
    return abs(set_point_mps - desired_mps) <= 0.5 * speed_step_mps


class ScriptedStart:
    """The actions that take one episode's ego to a start condition (first into the expert's set-point band, and for
    "left" into the leftmost lane), and the condition of recovery; `desired_mps` is the expert's desired speed."""

    def __init__(self, condition: str, desired_mps: float, config: Config) -> None:
        if condition not in CONDITIONS:
            raise ValueError(f"unknown start condition {condition!r}; known: {', '.join(CONDITIONS)}")
        self.condition, self.desired_mps, self.env = condition, desired_mps, config.env
        self._offset_steps = 0
        self._first_lane: int | None = None

    def action(self, traffic: TrafficView, expert_action: Action) -> Action | None:
        """The scripted action on the way to the start condition; None once it is reached (the driver takes over)."""
        ego, step = traffic.ego, self.env.speed_step_mps
        banded = in_band(traffic.set_point_mps, self.desired_mps, step)
        if self.condition == "left":
            self._first_lane = ego.lane if self._first_lane is None else self._first_lane
            if ego.changing_lane:
                return Action.KEEP
            if ego.lane > self._first_lane and banded and expert_action is Action.LANE_RIGHT:
                return None
            if ego.lane < traffic.lanes - 1 and (ego.lane == self._first_lane or banded):
                return Action.LANE_LEFT
        if self._offset_steps == 0 and not banded:
            return Action.ACCELERATE if traffic.set_point_mps < self.desired_mps else Action.DECELERATE
        if self.condition == "left":
            return Action.KEEP
        if self.condition == "low" and self._offset_steps < LOW_STEPS:
            self._offset_steps += 1
            return Action.DECELERATE
        if self.condition == "high" and traffic.set_point_mps < self.env.v_max_mps:
            self._offset_steps += 1
            return Action.ACCELERATE
        return None

    def recovered(self, traffic: TrafficView, expert_action: Action) -> bool:
        """The ego is back where the expert would keep it."""
        if self.condition == "left":
            return expert_action is not Action.LANE_RIGHT
        return in_band(traffic.set_point_mps, self.desired_mps, self.env.speed_step_mps)


RECOVERY_COLUMNS = ("seed", "condition", "started", "start_decisions", "ended", "recovered", "decisions_to_recover",
                    "agreement")
"""One row per episode: its seed and condition; whether the start was reached and in how many decisions; whether the
episode ended before the driver recovered or reached the horizon; whether it recovered within the horizon, in how
many decisions (the horizon when it did not: censored), and its agreement with the expert over the decisions it
drove."""


@dataclass(frozen=True)
class RecoveryTask:
    """One recovery episode of `driver` on test seed `seed` (warm state `warm_state` of the test pool), the expert of
    style `style` asked at every decision."""

    config: Config
    driver: DriverSpec
    style: str
    condition: str
    seed: int
    warm_state: int
    horizon: int = HORIZON

    def run(self, context: WorkerContext) -> dict[str, Any]:
        config = self.config
        start = ScriptedStart(self.condition, STYLES[self.style].desired_speed_mps, config)
        expert = make_expert(self.style, config.env.speed_step_mps, config.expert.view_range_m)
        driver = self.driver.create(config, self.seed)
        env = context.env(config)
        observation, _ = env.reset(seed=self.seed, options={"pool": "test", "warm_state": self.warm_state})
        row: dict[str, Any] = {"seed": self.seed, "condition": self.condition, "started": False,
                               "start_decisions": 0, "ended": False, "recovered": False,
                               "decisions_to_recover": self.horizon, "agreement": np.nan}
        agreements: list[bool] = []
        while len(agreements) < self.horizon:
            traffic = env.traffic
            expert_action = expert.decide(traffic)
            scripted = None if row["started"] else start.action(traffic, expert_action)
            if scripted is not None:
                if row["start_decisions"] == START_LIMIT:
                    break
                action = int(scripted)
                row["start_decisions"] += 1
            else:
                row["started"] = True
                if start.recovered(traffic, expert_action):
                    row["recovered"], row["decisions_to_recover"] = True, len(agreements)
                    break
                action = int(driver(observation, traffic))
                agreements.append(action == expert_action)
            observation, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                row["ended"] = True
                break
        if agreements:
            row["agreement"] = float(np.mean(agreements))
        return row


def recovery_tasks(config: Config, drivers: list[DriverSpec], reference: ExpertDriver, seeds: list[int],
                   conditions: tuple[str, ...] = CONDITIONS, horizon: int = HORIZON) -> list[RecoveryTask]:
    """Every driver in every condition on every seed (episode k from warm state k mod `scenario.snapshots` of the
    test pool, as `evaluate` does), drivers, then conditions, then seeds."""
    return [RecoveryTask(config, driver, reference.style, condition, seed, k % config.scenario.snapshots, horizon)
            for driver in drivers for condition in conditions for k, seed in enumerate(seeds)]
