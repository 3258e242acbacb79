"""One controlled vehicle's decisions, for each ego of the env core (`ParallelHighwayEnv`): the action's command to
SUMO, the observation (LIDAR kernel), rewards, metrics, info and the end of its episode.

A decision is `command` (set-point and lane-change request), the simulation's period (`Simulation.advance_egos`),
then `finish` with the ego's period report. The reward of a decision is
longitudinal + lateral, or `env.collision_reward` when the ego collides (terminated); a stop at the end of a lane
that does not lead along its route (a missed exit, a lane end; `route_progress`) terminates with
`env.collision_reward` added; reaching the end of the route or the time limit truncates.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from sumo_rail.config import Config
from sumo_rail.sim import kernels, lidar
from sumo_rail.sim.actions import (
    Action,
    acceleration_command,
    command_for,
    paper_equivalent,
    split_acceleration_action,
)
from sumo_rail.sim.ego_past import EgoPast
from sumo_rail.sim.observation import acceleration_slot, control_slot
from sumo_rail.sim.period_safety import NO_READINGS, PeriodSafety
from sumo_rail.sim.rewards import EpisodeMetrics, OvertakeCounter, lateral_reward, longitudinal_reward, relations
from sumo_rail.sim.route_progress import RouteProgress, route_values, zip_merge_change
from sumo_rail.sim.simulation import Simulation
from sumo_rail.sim.traffic import TrafficView
from sumo_rail.sim.vehicles import EgoState, Neighbours, PeriodReport

_ACTIONS = tuple(Action)
_INTEGERS = (int, np.integer)
CONTEXT_MARGIN_M = 20.0
"""Extra context-subscription radius [m] so that long vehicles whose front is just out of LIDAR range are seen."""
_NO_ROUTE = (1.0, 0.0, 1.0, 1.0)
"""Route values passed to the kernel when the observation has no route block (not written)."""
StepResult = tuple[np.ndarray, float, bool, bool, dict[str, Any]]
"""(observation, reward, terminated, truncated, info) of one decision, as Gymnasium's `step` returns them."""


def checked_action(action: Any, space: spaces.Discrete) -> int:
    """`action` as an int; ValueError when it is not in `space` (Discrete(5), or the acceleration interface's
    Discrete(3 x bins))."""
    fast_path_valid = isinstance(action, _INTEGERS) and 0 <= action < space.n
    if not (fast_path_valid or space.contains(action)):
        raise ValueError(f"action must be an integer in [0, {space.n}), got {action!r}")
    return int(action)


def edge_rows(sim: Simulation) -> np.ndarray:
    """The road-edge boxes the LIDAR kernel sees, the edges' sides then the junctions', (S, 6) rows of centre x, y,
    axis x, y, half length, half width [m]."""
    edges = lidar.edge_boxes(np.concatenate([sim.road_edges(), sim.junction_edges()]))
    return np.hstack([edges.centre_xy, edges.axis_xy, edges.half_size_m])


class Ego:
    """The decision loop of one ego (SUMO vehicle `vehicle`) over one episode; `edges` are `edge_rows(sim)`, `past`
    what is known of it before its first decision (a recorded seat's lead-in)."""

    def __init__(self, config: Config, vehicle: str, edges: np.ndarray, past: EgoPast | None = None) -> None:
        self.config = config
        self.vehicle = vehicle
        self.edges = edges
        self.set_point_mps = config.env.v_min_mps
        """Cruise set-point [m/s]; under the acceleration interface, which has none, the speed that an acceleration of
        0 holds: the ego's speed at the decision."""
        self.accelerating = config.actions.interface == "acceleration"
        """Driven through the acceleration interface."""
        self.acceleration_mps2 = 0.0
        """The last commanded acceleration [m/s^2] (the acceleration interface); before the first decision, the last
        period's acceleration of a recorded seat's lead-in in its bin (what the seat's demonstrations show there), else
        0."""
        self.lane = 0
        self.changing_lane = False
        self.start_time_s = self.start_position_m = 0.0
        self.metrics = EpisodeMetrics()
        self.overtakes = OvertakeCounter()
        self.traffic: TrafficView | None = None
        """The ego and its neighbours at the last decision (read directly from SUMO, not from the LIDAR)."""
        self.last_observation = np.zeros(0, dtype=np.float32)
        self.last_action: Action | None = None
        self.route_progress = RouteProgress(config.observation.route_range_m)
        self.past = past or EgoPast()
        """The ego's own past (the observation's history block, `observation.history`)."""
        self.period_safety = PeriodSafety(config.scenario.step_length_s, config.env.decision_period_s)
        self.safety_readings: dict[str, float] = NO_READINGS
        """The last period's safety readings (`period_safety.READINGS`, in `info`)."""
        self.requested_lane: int | None = None
        self._kernel_settings = (config.lidar.beams, config.lidar.range_m, config.env.v_min_mps, config.env.v_max_mps,
                                 config.scenario.lanes, config.observation.lane_block == 1,
                                 config.observation.route_block == 1)
        """The observation kernel's arguments that the configuration fixes (`observation`)."""

    def start(self, sim: Simulation) -> tuple[np.ndarray, dict[str, Any]]:
        """Begin the episode once the ego is on the road: its set-point is its speed, within [v_min, v_max];
        returns the first observation and info."""
        cfg = self.config
        ego, neighbours = sim.observe(self.vehicle)
        if self.accelerating:
            self.set_point_mps = ego.speed_mps
            sim.take_acceleration_control(self.vehicle, cfg.actions.acceleration_max_mps2)
        else:
            self.set_point_mps = min(max(ego.speed_mps, cfg.env.v_min_mps), self.top_speed_mps(sim))
            sim.set_cruise_speed(self.set_point_mps, self.vehicle)
        self.lane = ego.lane
        self.changing_lane = ego.changing_lane
        self.start_time_s, self.start_position_m = sim.time_s, ego.lane_position_m
        self.route_progress.update(ego, sim.time_s, self.metrics)
        self.overtakes.update(neighbours.ids, self._relations(ego, neighbours))
        self.past.record(sim.time_s, ego.speed_mps, 0.0, ego.lane)
        if self.accelerating:
            lead_in = self.past.period_acceleration(sim.time_s, cfg.env.decision_period_s)
            self.acceleration_mps2 = cfg.actions.acceleration_mps2(cfg.actions.nearest_bin(lead_in))
        self.last_observation = self.observation(ego, neighbours, ego.changing_lane, sim.time_s)
        self.traffic = TrafficView(ego, neighbours, self.set_point_mps, cfg.scenario.lanes)
        return self.last_observation, self._info(ego, 0.0, 0.0, 0.0, False, "")

    def top_speed_mps(self, sim: Simulation) -> float:
        """The highest set-point and the speed of the full longitudinal reward [m/s]: env.v_max_mps, or the road's
        speed limit when lower (the ego keeps to it)."""
        return min(self.config.env.v_max_mps, sim.speed_limit_mps)

    def command(self, sim: Simulation, action: int) -> None:
        """Give SUMO the command of this decision's `action` (`checked_action`; before the period's steps: the env's
        actions' controller, `sumo_rail.sim.controllers`). An acceleration-interface action is counted among the
        paper's five (`paper_equivalent`)."""
        cfg, metrics = self.config, self.metrics
        route = self.traffic.ego.route if self.traffic is not None else None
        lowest, highest = (0, cfg.scenario.lanes - 1) if route is None else (route.lowest_lane, route.highest_lane)
        if self.accelerating:
            acceleration_bin, lateral = split_acceleration_action(action, cfg.actions)
            accelerating = acceleration_command(acceleration_bin, lateral, cfg.actions, self.lane, highest + 1,
                                                lowest)
            self.acceleration_mps2 = accelerating.acceleration_mps2
            sim.set_acceleration(accelerating.acceleration_mps2, cfg.env.decision_period_s, self.vehicle)
            action = paper_equivalent(accelerating.acceleration_mps2, lateral)
            target_lane, invalid = accelerating.target_lane, accelerating.invalid
        else:
            action = _ACTIONS[action]
            command = command_for(action, self.set_point_mps, self.lane, highest + 1, cfg.env.speed_step_mps,
                                  cfg.env.v_min_mps, self.top_speed_mps(sim), lowest)
            if command.set_point_mps != self.set_point_mps:
                self.set_point_mps = command.set_point_mps
                sim.set_cruise_speed(self.set_point_mps, self.vehicle)
            target_lane, invalid = command.target_lane, command.invalid
        self.last_action = action
        self.requested_lane = target_lane
        if target_lane is not None:
            zip_merge = route is not None and zip_merge_change(route, self.lane, target_lane, cfg.env.zip_merge_m)
            sim.request_lane_change(target_lane, cfg.env.decision_period_s, self.vehicle, zip_merge)
        metrics.decisions += 1
        metrics.action_counts[action] += 1
        metrics.invalid_actions += invalid

    def finish(self, sim: Simulation, report: PeriodReport) -> StepResult:
        """The decision's outcome after the period's steps, from the ego's period report."""
        cfg, metrics = self.config, self.metrics
        metrics.teleports += report.teleports
        if report.ego_collided or report.ego_left_network:
            return self._gone(sim, report)
        ego, neighbours = sim.observe(self.vehicle)
        self.safety_readings = self.period_safety.update(report, ego, neighbours, self.requested_lane,
                                                         self.changing_lane)
        # A change under way at either end of the period, or one that moved the ego to another lane within it.
        changing = self.changing_lane or ego.changing_lane or ego.lane != self.lane
        self.changing_lane = ego.changing_lane
        metrics.lane_changes += abs(ego.lane - self.lane)
        self.lane = ego.lane
        r_long = longitudinal_reward(ego.speed_mps, cfg.env.v_min_mps, self.top_speed_mps(sim))
        r_lat = lateral_reward(changing, cfg.env.lane_change_reward)
        metrics.longitudinal_reward += r_long
        metrics.lateral_reward += r_lat
        metrics.hard_braking += report.min_acceleration_mps2 < -cfg.env.hard_brake_mps2
        metrics.overtakes += self.overtakes.update(neighbours.ids, self._relations(ego, neighbours))
        metrics.overtaken = self.overtakes.overtaken
        metrics.speed_sum_mps += ego.speed_mps
        now_s = sim.time_s
        metrics.simulated_s = now_s - self.start_time_s
        metrics.distance_m = ego.lane_position_m - self.start_position_m
        self.route_progress.update(ego, now_s, metrics)
        failure = self.route_progress.failure(ego)
        reason = failure
        if failure:
            metrics.missed_exits += failure == "missed_exit"
            metrics.lane_end_stops += failure == "lane_end"
        elif ego.lane_position_m >= sim.route_map.length_m - cfg.env.end_margin_m:
            reason = "end_of_road"
        elif metrics.simulated_s >= cfg.env.max_episode_s - 1e-9:
            reason = "time_limit"
        if self.accelerating:
            self.set_point_mps = ego.speed_mps
        self.past.record(now_s, ego.speed_mps, report.accelerations_mps2[-1] if report.accelerations_mps2 else 0.0,
                         ego.lane)
        self.last_observation = self.observation(ego, neighbours, ego.changing_lane, now_s)
        self.traffic = TrafficView(ego, neighbours, self.set_point_mps, cfg.scenario.lanes)
        if failure:
            sim.remove_ego(self.vehicle)  # standing at the lane's end, it would block it for the egos that drive on
            info = self._info(ego, r_long, r_lat, cfg.env.collision_reward, changing, reason)
            return self.last_observation, r_long + r_lat + cfg.env.collision_reward, True, False, info
        info = self._info(ego, r_long, r_lat, 0.0, changing, reason)
        return self.last_observation, r_long + r_lat, False, bool(reason), info

    def _gone(self, sim: Simulation, report: PeriodReport) -> StepResult:
        """The ego collided (terminated) or left the network (truncated); the last observation and the last known
        state (speed, lane, position, set-point, no lane change under way) are repeated."""
        metrics = self.metrics
        metrics.simulated_s = (sim.time_s if report.left_at_s is None else report.left_at_s) - self.start_time_s
        if report.ego_collided:
            metrics.collisions += 1
            reward, reason = self.config.env.collision_reward, "collision"
        else:
            reward, reason = 0.0, "end_of_road"
        if self.traffic is None:
            raise RuntimeError("the ego left before its first decision")
        last = self.traffic.ego
        info = self._totals() | {"speed_mps": last.speed_mps, "lane": last.lane, "position_m": last.lane_position_m,
                                 "set_point_mps": self.set_point_mps, "lane_change_in_progress": False,
                                 "reward_longitudinal": 0.0, "reward_lateral": 0.0, "reward_collision": reward,
                                 "termination": reason, **self.period_safety.update(report, None, None, None, True)}
        return self.last_observation, reward, report.ego_collided, not report.ego_collided, info

    def action_label(self) -> str:
        """The last decision in words for a frame: the paper's action, or the commanded acceleration [m/s^2] and the
        lane decision; "-" before the first."""
        if self.last_action is None:
            return "-"
        if not self.accelerating:
            return self.last_action.name
        lane = {Action.LANE_LEFT: " LEFT", Action.LANE_RIGHT: " RIGHT"}.get(self.last_action, "")
        return f"{self.acceleration_mps2:+.2f} m/s^2{lane}"

    def _relations(self, ego: EgoState, neighbours: Neighbours) -> list[int]:
        return relations(ego.lane_position_m, ego.length_m, neighbours.lane_position_m, neighbours.length_m)

    def observation(self, ego: EgoState, neighbours: Neighbours, lane_change_in_progress: bool,
                    now_s: float) -> np.ndarray:
        """The observation at `now_s` [s], from the compiled kernel (the numpy `lidar.scan` + `build_observation`,
        `lane_block` and `route_block` are its reference), then the history block (`ego_past`)."""
        cfg = self.config
        route = (route_values(ego, cfg.observation.route_range_m, cfg.scenario.lanes) if cfg.observation.route_block
                 else _NO_ROUTE)
        observation = kernels.observation_vector(
            neighbours.front_xy, neighbours.heading_rad, neighbours.length_m, neighbours.width_m,
            neighbours.speed_mps, neighbours.lane_position_m, neighbours.lane, self.edges, ego.front_x, ego.front_y,
            ego.heading_rad, ego.length_m, ego.speed_mps, self.set_point_mps, ego.lane_position_m, ego.lane,
            lane_change_in_progress, *self._kernel_settings, *route)
        if self.accelerating:
            observation[control_slot(cfg)] = acceleration_slot(self.acceleration_mps2, cfg.actions)
        if cfg.observation.history:
            observation = np.concatenate([observation, self.past.block(now_s, ego.lane, cfg.observation.history,
                                                                       cfg.env.v_max_mps)])
        return observation

    def _totals(self) -> dict[str, Any]:
        m = self.metrics
        return {"lane_changes": m.lane_changes, "overtakes": m.overtakes, "overtaken": m.overtaken,
                "collisions": m.collisions, "hard_braking": m.hard_braking, "teleports": m.teleports,
                "invalid_actions": m.invalid_actions, "time_s": m.simulated_s, "distance_m": m.distance_m,
                "merges": m.merges, "missed_exits": m.missed_exits, "lane_end_stops": m.lane_end_stops}

    def _info(self, ego: EgoState, r_long: float, r_lat: float, r_collision: float, changing: bool,
              reason: str) -> dict[str, Any]:
        info = self._totals()  # then the decision's entries, stored one by one: cheaper than merging two dicts
        info["speed_mps"], info["lane"], info["position_m"] = ego.speed_mps, ego.lane, ego.lane_position_m
        info["set_point_mps"], info["lane_change_in_progress"] = self.set_point_mps, changing
        info["reward_longitudinal"], info["reward_lateral"], info["reward_collision"] = r_long, r_lat, r_collision
        info["termination"] = reason
        info.update(self.safety_readings)
        return info
