"""The observation vector: its layout, bounds and assembly from LIDAR and ego readings.

Layout (float32), with B LIDAR beams and L lanes:
- [0, B): LIDAR distance of beam i / r_max, in [0, 1] (1 = nothing within range);
- [B, 2B): relative speed along beam i / v_max, clipped to [-1, 1] (positive = moving away);
- 2B: ego speed / v_max, clipped to [0, 2];
- 2B + 1: cruise set-point, (v_set - v_min) / (v_max - v_min), in [0, 1] (the driver knows its own setting); under
  the acceleration interface the last commanded acceleration instead, 0 at its range's lowest, 1 at its highest;
- [2B + 2, 2B + 2 + L): current lane, one-hot (index 0 = the main road's rightmost lane; an acceleration lane or
  ramp right of it reads as lane 0);
- 2B + 2 + L: 1 while the ego is between lanes (a lane change under way), else 0;
- with `observation.lane_block = 1`, 12 more: for the lane right of, at and left of the ego, the gap to the
  nearest vehicle ahead / r_max, its relative speed / v_max, then the same behind
  (`sumo_rail.sim.traffic.lane_block`);
- with `observation.route_block = 1`, 4 more: how far the ego's lane leads along its route, the lanes to move to
  the nearest lane that leads farthest, the distances to the next merge and diverge
  (`sumo_rail.sim.route_progress.route_block`);
- with `observation.history = H`, 3 H more: for each second back, the ego's speed, acceleration and lanes moved
  since (`sumo_rail.sim.ego_past`).
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from sumo_rail.action_config import ActionConfig
from sumo_rail.config import Config
from sumo_rail.sim.ego_past import HISTORY_FIELDS
from sumo_rail.sim.route_progress import ROUTE_BLOCK_FIELDS
from sumo_rail.sim.traffic import LANE_BLOCK_FIELDS, LANE_BLOCK_LANES


def observation_names(config: Config) -> list[str]:
    """Name of each observation entry, in order."""
    beams = config.lidar.beams
    return ([f"lidar_distance_{i:02d}" for i in range(beams)]
            + [f"lidar_relative_speed_{i:02d}" for i in range(beams)]
            + ["ego_speed", "last_acceleration" if config.actions.interface == "acceleration" else "cruise_set_point"]
            + [f"lane_{k}" for k in range(config.scenario.lanes)]
            + ["lane_change_in_progress"]
            + ([f"{lane}_lane_{name}" for lane in LANE_BLOCK_LANES for name in LANE_BLOCK_FIELDS]
               if config.observation.lane_block else [])
            + (list(ROUTE_BLOCK_FIELDS) if config.observation.route_block else [])
            + [f"history_{name}_{k}s" for k in range(1, config.observation.history + 1) for name in HISTORY_FIELDS])


def control_slot(config: Config) -> int:
    """The index of the entry that shows the ego's own control: the cruise set-point (the paper's interface) or the
    last commanded acceleration (the acceleration interface, `acceleration_slot`)."""
    return 2 * config.lidar.beams + 1


def acceleration_slot(acceleration_mps2: float, actions: ActionConfig) -> float:
    """The last commanded acceleration [m/s^2] as its observation entry: 0 at the interface's lowest, 1 at its
    highest."""
    low, high = actions.acceleration_min_mps2, actions.acceleration_max_mps2
    return (acceleration_mps2 - low) / (high - low)


def observation_space(config: Config) -> spaces.Box:
    """Bounds of every entry, matching the layout above."""
    beams, lanes = config.lidar.beams, config.scenario.lanes
    block, route = 3 * config.observation.lane_block, config.observation.route_block
    history = config.observation.history
    low = np.concatenate([np.zeros(beams), -np.ones(beams), [0.0, 0.0], np.zeros(lanes), [0.0], [0, -1, 0, -1] * block,
                          [0, -1, 0, 0] * route, [0, -1, -1] * history])
    high = np.concatenate([np.ones(beams), np.ones(beams), [2.0, 1.0], np.ones(lanes), [1.0], [1, 1, 1, 1] * block,
                           [1, 1, 1, 1] * route, [2, 1, 1] * history])
    return spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)


def build_observation(config: Config, distances_m: np.ndarray, relative_speeds_mps: np.ndarray, speed_mps: float,
                      set_point_mps: float, lane: int, lane_change_in_progress: bool) -> np.ndarray:
    """Assemble the normalised float32 observation."""
    env, beams = config.env, config.lidar.beams
    observation = np.empty(2 * beams + 3 + config.scenario.lanes, dtype=np.float32)
    np.minimum(distances_m * (1.0 / config.lidar.range_m), 1.0, out=observation[:beams], casting="same_kind")
    relative = np.maximum(relative_speeds_mps * (1.0 / env.v_max_mps), -1.0)
    np.minimum(relative, 1.0, out=observation[beams:2 * beams], casting="same_kind")
    observation[2 * beams:] = 0.0
    observation[2 * beams] = min(max(speed_mps / env.v_max_mps, 0.0), 2.0)
    observation[2 * beams + 1] = (set_point_mps - env.v_min_mps) / (env.v_max_mps - env.v_min_mps)
    observation[2 * beams + 2 + lane] = 1.0
    observation[-1] = 1.0 if lane_change_in_progress else 0.0
    return observation
