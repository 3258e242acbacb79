"""`HighwayEnv`: the Gymnasium environment composing the simulation, LIDAR, actions and rewards.

Each reset draws, from the env's `np_random`, the warm traffic state, SUMO's seed, the ego's start lane and
position, so `reset(seed=s)` followed by the same actions reproduces the same episode. `reset(options=...)`
may choose the warm-state pool (`"pool"`: "train", the default, "validation" or "test"; see
`sumo_rail.sim.simulation`) and fix the warm state (`"warm_state"`: its index in the pool) instead of drawing it.
One decision lasts `env.decision_period_s`; the reward of a decision is longitudinal + lateral, or
`collision_reward` when the ego collides (the episode then terminates).
Reaching the end of the road or the time limit truncates it.

`config` may be a `Config`, a nested mapping `{"scenario": {"lanes": 3}}` or the path of a TOML file, as
`gymnasium.make(ENV_ID, config=...)` passes it. `render_mode="rgb_array"` makes `render()` return a bird's-eye
frame of the last decision (`sumo_rail.sim.render`); `"human"` drives SUMO in sumo-gui, following the ego.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import gymnasium
import numpy as np
from gymnasium import spaces

from sumo_rail.config import Config
from sumo_rail.sim import kernels, lidar
from sumo_rail.sim.actions import Action, command_for
from sumo_rail.sim.observation import observation_space
from sumo_rail.sim.rewards import EpisodeMetrics, OvertakeCounter, lateral_reward, longitudinal_reward, relations
from sumo_rail.sim.simulation import TRANSPORTS, WARM_STATE_POOLS, EgoState, Neighbours, PeriodReport, Simulation
from sumo_rail.sim.traffic import TrafficView, lane_block

if TYPE_CHECKING:
    from sumo_rail.sim.render import FrameRenderer

_SUMO_SEED_BOUND = 2**31 - 1
_ACTIONS = tuple(Action)
_INTEGERS = (int, np.integer)
RENDER_MODES = ("human", "rgb_array")
"""human: sumo-gui (needs a display); rgb_array: `render()` returns a bird's-eye frame (no display needed)."""


@dataclass(frozen=True)
class EpisodeStart:
    """Everything a reset draws from the env's `np_random`, in this order."""

    snapshot: int
    sumo_seed: int
    ego_lane: int
    ego_position_m: float

    @classmethod
    def draw(cls, rng: np.random.Generator, config: Config, snapshots: int) -> EpisodeStart:
        return cls(snapshot=int(rng.integers(snapshots)),
                   sumo_seed=int(rng.integers(_SUMO_SEED_BOUND)),
                   ego_lane=int(rng.integers(config.scenario.lanes)),
                   ego_position_m=float(rng.uniform(config.env.ego_start_min_m, config.env.ego_start_max_m)))


def _warm_state_options(options: dict[str, Any], snapshots: int) -> tuple[str, int | None]:
    """The pool and fixed warm state asked for in reset's options (ValueError on unknown keys or values)."""
    unknown = set(options) - {"pool", "warm_state"}
    if unknown:
        raise ValueError(f"unknown reset options {sorted(unknown)}; known: 'pool', 'warm_state'")
    pool = options.get("pool", "train")
    if pool not in WARM_STATE_POOLS:
        raise ValueError(f"reset option 'pool' must be one of {', '.join(WARM_STATE_POOLS)}, got {pool!r}")
    warm_state = options.get("warm_state")
    if warm_state is not None and not (isinstance(warm_state, int | np.integer) and 0 <= warm_state < snapshots):
        raise ValueError(f"reset option 'warm_state' must be an integer in [0, {snapshots}), got {warm_state!r}")
    return pool, None if warm_state is None else int(warm_state)


_CONTEXT_MARGIN_M = 20.0
"""Extra context-subscription radius so that long vehicles whose front is just out of LIDAR range are seen."""


class HighwayEnv(gymnasium.Env[np.ndarray, np.int64]):
    """Five-lane SUMO highway with a 24-beam LIDAR and five high-level actions; `transport` drives SUMO through
    libsumo (in-process, the fast default) or traci (a `sumo` process over a socket); render_mode "human" (sumo-gui)
    implies traci, with `gui_delay_ms` [ms] of wall time per SUMO step (100: real time at 0.1 s steps)."""

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 2}  # noqa: RUF012 - Gymnasium's class attribute

    def __init__(self, config: Config | Mapping[str, Any] | str | Path | None = None, render_mode: str | None = None,
                 transport: str = "libsumo", gui_delay_ms: float = 100.0) -> None:
        if render_mode not in (None, *RENDER_MODES):
            raise ValueError(f"render_mode must be None, 'human' (sumo-gui) or 'rgb_array', got {render_mode!r}")
        if transport not in TRANSPORTS:
            raise ValueError(f"transport must be one of {', '.join(TRANSPORTS)}, got {transport!r}")
        if not (isinstance(gui_delay_ms, int | float) and gui_delay_ms >= 0):
            raise ValueError(f"gui_delay_ms must be a number of milliseconds >= 0, got {gui_delay_ms!r}")
        self.transport = transport
        self.config = Config.coerce(config)
        self.render_mode = render_mode
        self.gui_delay_ms = float(gui_delay_ms)
        # one frame per decision: videos play in real time
        self.metadata = {**self.metadata, "render_fps": 1.0 / self.config.env.decision_period_s}
        self.observation_space = observation_space(self.config)
        self.action_space = spaces.Discrete(len(Action))
        scenario, env = self.config.scenario, self.config.env
        self._steps_per_decision = env.steps_per_decision(scenario.step_length_s)
        self._sim: Simulation | None = None
        self._edges: np.ndarray | None = None
        """Road-edge boxes, (S, 6) rows of centre x, y, axis x, y, half length, half width [m]."""
        self._set_point = env.v_min_mps
        self._lane = 0
        self._changing_lane = False
        self._start_time_s = self._start_position_m = 0.0
        self._last_observation = np.zeros(self.observation_space.shape, dtype=np.float32)
        self._metrics = EpisodeMetrics()
        self._overtakes = OvertakeCounter()
        self._traffic: TrafficView | None = None
        self._last_action: Action | None = None
        self._renderer: FrameRenderer | None = None

    @property
    def metrics(self) -> EpisodeMetrics:
        """Totals of the current episode."""
        return self._metrics

    @property
    def traffic(self) -> TrafficView:
        """The ego and its neighbours at the last decision (read directly from SUMO, not from the LIDAR)."""
        if self._traffic is None:
            raise RuntimeError("call reset() before reading the traffic")
        return self._traffic

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None,
              ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        cfg = self.config
        if self._sim is None:
            self._sim = Simulation(cfg.scenario, cfg.lidar.range_m + _CONTEXT_MARGIN_M,
                                   gui=self.render_mode == "human", transport=self.transport,
                                   gui_delay_ms=self.gui_delay_ms)
        sim = self._sim
        start = EpisodeStart.draw(self.np_random, cfg, sim.snapshot_count)
        pool, warm_state = _warm_state_options(options or {}, sim.snapshot_count)
        if warm_state is not None:
            start = dataclasses.replace(start, snapshot=warm_state)
        sim.reset(**dataclasses.asdict(start), pool=pool)
        if self._edges is None:
            edges = lidar.edge_boxes(sim.road_edges())
            self._edges = np.hstack([edges.centre_xy, edges.axis_xy, edges.half_size_m])
        ego, neighbours = sim.observe()
        self._set_point = min(max(ego.speed_mps, cfg.env.v_min_mps), cfg.env.v_max_mps)
        sim.set_cruise_speed(self._set_point)
        self._lane = ego.lane
        self._changing_lane = ego.changing_lane
        self._start_time_s, self._start_position_m = sim.time_s, ego.lane_position_m
        self._metrics = EpisodeMetrics()
        self._overtakes = OvertakeCounter()
        self._overtakes.update(neighbours.ids, self._relations(ego, neighbours))
        self._last_observation = self._observe(ego, neighbours, ego.changing_lane)
        self._traffic = TrafficView(ego, neighbours, self._set_point, cfg.scenario.lanes)
        self._last_action = None
        return self._last_observation, self._info(ego, 0.0, 0.0, 0.0, False, "")

    def step(self, action: int | np.integer) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self._sim is None:
            raise RuntimeError("call reset() before step()")
        fast_path_valid = isinstance(action, _INTEGERS) and 0 <= action < len(_ACTIONS)
        if not (fast_path_valid or self.action_space.contains(action)):
            raise ValueError(f"action must be an integer in [0, {self.action_space.n}), got {action!r}")
        cfg, sim, metrics = self.config, self._sim, self._metrics
        chosen = self._last_action = _ACTIONS[int(action)]
        command = command_for(chosen, self._set_point, self._lane, cfg.scenario.lanes, cfg.env.speed_step_mps,
                              cfg.env.v_min_mps, cfg.env.v_max_mps)
        if command.set_point_mps != self._set_point:
            self._set_point = command.set_point_mps
            sim.set_cruise_speed(self._set_point)
        if command.target_lane is not None:
            sim.request_lane_change(command.target_lane, cfg.env.decision_period_s)
        was_changing_lane = self._changing_lane
        report = sim.advance(self._steps_per_decision)
        metrics.decisions += 1
        metrics.action_counts[chosen] += 1
        metrics.invalid_actions += command.invalid
        metrics.teleports += report.teleports
        if report.ego_collided or report.ego_left_network:
            return self._ego_gone(report)
        ego, neighbours = sim.observe()
        # A change under way at either end of the period, or one that moved the ego to another lane within it.
        changing = was_changing_lane or ego.changing_lane or ego.lane != self._lane
        self._changing_lane = ego.changing_lane
        metrics.lane_changes += abs(ego.lane - self._lane)
        self._lane = ego.lane
        r_long = longitudinal_reward(ego.speed_mps, cfg.env.v_min_mps, cfg.env.v_max_mps)
        r_lat = lateral_reward(changing, cfg.env.lane_change_reward)
        metrics.longitudinal_reward += r_long
        metrics.lateral_reward += r_lat
        metrics.hard_braking += report.min_acceleration_mps2 < -cfg.env.hard_brake_mps2
        metrics.overtakes += self._overtakes.update(neighbours.ids, self._relations(ego, neighbours))
        metrics.overtaken = self._overtakes.overtaken
        metrics.speed_sum_mps += ego.speed_mps
        metrics.simulated_s = sim.time_s - self._start_time_s
        metrics.distance_m = ego.lane_position_m - self._start_position_m
        reason = ""
        if ego.lane_position_m >= cfg.scenario.length_m - cfg.env.end_margin_m:
            reason = "end_of_road"
        elif metrics.simulated_s >= cfg.env.max_episode_s - 1e-9:
            reason = "time_limit"
        self._last_observation = self._observe(ego, neighbours, ego.changing_lane)
        self._traffic = TrafficView(ego, neighbours, self._set_point, cfg.scenario.lanes)
        info = self._info(ego, r_long, r_lat, 0.0, changing, reason)
        return self._last_observation, r_long + r_lat, False, bool(reason), info

    def _ego_gone(self, report: PeriodReport) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """The ego collided (terminated) or left the network (truncated); the last observation is repeated."""
        metrics = self._metrics
        metrics.simulated_s = self._sim.time_s - self._start_time_s if self._sim else metrics.simulated_s
        if report.ego_collided:
            metrics.collisions += 1
            reward, reason = self.config.env.collision_reward, "collision"
        else:
            reward, reason = 0.0, "end_of_road"
        info = self._totals() | {"reward_longitudinal": 0.0, "reward_lateral": 0.0,
                                 "reward_collision": reward, "termination": reason}
        return self._last_observation, reward, report.ego_collided, not report.ego_collided, info

    def _relations(self, ego: EgoState, neighbours: Neighbours) -> np.ndarray:
        return relations(ego.lane_position_m, ego.length_m, neighbours.lane_position_m, neighbours.length_m)

    def _observe(self, ego: EgoState, neighbours: Neighbours, lane_change_in_progress: bool) -> np.ndarray:
        """The observation, from the compiled kernel (the numpy `lidar.scan` + `build_observation` is its reference)."""
        cfg = self.config
        ego_row = np.array([ego.front_x, ego.front_y, ego.heading_rad, ego.length_m, ego.speed_mps, self._set_point])
        observation = kernels.observation_vector(
            neighbours.front_xy, neighbours.heading_rad, neighbours.length_m, neighbours.width_m,
            neighbours.speed_mps, self._edges, ego_row, ego.lane, lane_change_in_progress, cfg.lidar.beams,
            cfg.lidar.range_m, cfg.env.v_min_mps, cfg.env.v_max_mps, cfg.scenario.lanes)
        if cfg.observation.lane_block:
            traffic = TrafficView(ego, neighbours, self._set_point, cfg.scenario.lanes)
            observation = np.concatenate([observation, lane_block(traffic, cfg.lidar.range_m, cfg.env.v_max_mps)])
        return observation

    def _totals(self) -> dict[str, Any]:
        m = self._metrics
        return {"lane_changes": m.lane_changes, "overtakes": m.overtakes, "overtaken": m.overtaken,
                "collisions": m.collisions, "hard_braking": m.hard_braking, "teleports": m.teleports,
                "invalid_actions": m.invalid_actions, "time_s": m.simulated_s, "distance_m": m.distance_m}

    def _info(self, ego: EgoState, r_long: float, r_lat: float, r_collision: float, changing: bool,
              reason: str) -> dict[str, Any]:
        return self._totals() | {
            "speed_mps": ego.speed_mps, "lane": ego.lane, "position_m": ego.lane_position_m,
            "set_point_mps": self._set_point, "lane_change_in_progress": changing,
            "reward_longitudinal": r_long, "reward_lateral": r_lat, "reward_collision": r_collision,
            "termination": reason,
        }

    def render(self) -> np.ndarray | None:
        """With render_mode "rgb_array", the bird's-eye frame of the last decision (`frame()`); with "human",
        sumo-gui draws by itself and this returns None."""
        return self.frame() if self.render_mode == "rgb_array" else None

    def frame(self) -> np.ndarray:
        """A bird's-eye RGB frame of the last decision, shape (H, W, 3) uint8, whatever the render mode: the road,
        every vehicle in LIDAR range coloured by type, the ego, its LIDAR beams and hits, and its speed,
        set-point, lane and last action."""
        from sumo_rail.sim.render import FrameRenderer, FrameText

        if self._sim is None or self._traffic is None:
            raise RuntimeError("call reset() before render()")
        if self._renderer is None:
            self._renderer = FrameRenderer(self._sim.road_edges(), self.config.scenario.lanes)
        cfg, traffic = self.config, self._traffic
        # the observation holds distance / r_max, clipped to 1: exactly what the policy saw
        distances = self._last_observation[:cfg.lidar.beams].astype(np.float64) * cfg.lidar.range_m
        text = FrameText(self._sim.time_s, traffic.ego.speed_mps, traffic.set_point_mps, traffic.ego.lane,
                         cfg.scenario.lanes, "-" if self._last_action is None else self._last_action.name,
                         self._metrics.decisions)
        return self._renderer.draw(traffic.ego, traffic.neighbours, self._sim.vehicle_types(traffic.neighbours.ids),
                                   distances, cfg.lidar.range_m, text)

    def gui_screenshot(self, path: str | Path, width_px: int = 1280, height_px: int = 800) -> None:
        """With render_mode "human": save sumo-gui's view as a PNG at `path` when the next step is drawn."""
        if self._sim is None:
            raise RuntimeError("call reset() before gui_screenshot()")
        self._sim.screenshot(Path(path), width_px, height_px)

    def close(self) -> None:
        if self._sim is not None:
            self._sim.close()
            self._sim = None
        super().close()
