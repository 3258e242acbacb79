"""`HighwayEnv`: the Gymnasium environment composing the simulation, LIDAR, actions and rewards.

Each reset draws, from the env's `np_random`, the warm traffic state, SUMO's seed, the ego's start lane and
position (drawn again where that place has no room, `sumo_rail.sim.starts`), so `reset(seed=s)` followed by the
same actions reproduces the same episode. `reset(options=...)`
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

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import gymnasium
import numpy as np
from gymnasium import spaces

from sumo_rail.config import Config
from sumo_rail.sim import network
from sumo_rail.sim.actions import Action
from sumo_rail.sim.ego import CONTEXT_MARGIN_M, Ego, checked_action, edge_rows
from sumo_rail.sim.observation import observation_space
from sumo_rail.sim.rewards import EpisodeMetrics
from sumo_rail.sim.simulation import EGO_ID, TRANSPORTS, Simulation
from sumo_rail.sim.starts import start_egos
from sumo_rail.sim.traffic import TrafficView

if TYPE_CHECKING:
    from sumo_rail.sim.render import FrameRenderer

__all__ = ["RENDER_MODES", "HighwayEnv", "TrafficView", "start_ego"]
RENDER_MODES = ("human", "rgb_array")
"""human: sumo-gui (needs a display); rgb_array: `render()` returns a bird's-eye frame (no display needed)."""


def start_ego(sim: Simulation, rng: np.random.Generator, config: Config, options: dict[str, Any]) -> None:
    """What `HighwayEnv.reset` does to SUMO: reset `sim` with the single ego at its start drawn from `rng`
    (`starts.start_egos`), in the warm state and pool that reset's `options` choose."""
    start_egos(sim, rng, config, 1, options, lambda start, pool: sim.reset(
        start.warm_state, start.sumo_seed, start.lanes[0], start.positions_m[0], pool))


class HighwayEnv(gymnasium.Env[np.ndarray, np.int64]):
    """Five-lane SUMO highway with a 24-beam LIDAR and five high-level actions; `transport` drives SUMO through
    libsumo (in-process, fast; one simulation per process) or traci (a `sumo` process over a socket); "auto", the
    default, takes libsumo unless another env of this process holds it, then traci; render_mode "human" (sumo-gui)
    implies traci, with `gui_delay_ms` [ms] of wall time per SUMO step (100: real time at 0.1 s steps)."""

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 2}  # noqa: RUF012 - Gymnasium's class attribute

    def __init__(self, config: Config | Mapping[str, Any] | str | Path | None = None, render_mode: str | None = None,
                 transport: str = "auto", gui_delay_ms: float = 100.0) -> None:
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
        """Road-edge boxes, `ego.edge_rows`."""
        self._ego: Ego | None = None
        self._renderer: FrameRenderer | None = None

    @property
    def metrics(self) -> EpisodeMetrics:
        """Totals of the current episode."""
        return self._ego.metrics if self._ego is not None else EpisodeMetrics()

    @property
    def traffic(self) -> TrafficView:
        """The ego and its neighbours at the last decision (read directly from SUMO, not from the LIDAR)."""
        if self._ego is None or self._ego.traffic is None:
            raise RuntimeError("call reset() before reading the traffic")
        return self._ego.traffic

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None,
              ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        cfg = self.config
        if self._sim is None:
            network.check_user_route(cfg)
            self._sim = Simulation(cfg.scenario, cfg.lidar.range_m + CONTEXT_MARGIN_M,
                                   gui=self.render_mode == "human", transport=self.transport,
                                   gui_delay_ms=self.gui_delay_ms)
        sim = self._sim
        start_ego(sim, self.np_random, cfg, options or {})
        if self._edges is None:
            self._edges = edge_rows(sim)
        self._ego = Ego(cfg, EGO_ID, self._edges)
        return self._ego.start(sim)

    def step(self, action: int | np.integer) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self._sim is None or self._ego is None:
            raise RuntimeError("call reset() before step()")
        ego = self._ego
        ego.command(self._sim, checked_action(action, self.action_space))
        return ego.finish(self._sim, self._sim.advance(self._steps_per_decision, ego.period_safety.watched()))

    def render(self) -> np.ndarray | None:
        """With render_mode "rgb_array", the bird's-eye frame of the last decision (`frame()`); with "human",
        sumo-gui draws by itself and this returns None."""
        return self.frame() if self.render_mode == "rgb_array" else None

    def frame(self) -> np.ndarray:
        """A bird's-eye RGB frame of the last decision, shape (H, W, 3) uint8, whatever the render mode: the road,
        every vehicle in LIDAR range coloured by type, the ego, its LIDAR beams and hits, and its speed,
        set-point, lane and last action."""
        from sumo_rail.sim.render import FrameRenderer, FrameText

        if self._sim is None or self._ego is None or self._ego.traffic is None:
            raise RuntimeError("call reset() before render()")
        if self._renderer is None:
            if self._sim.route_map.single_edge:
                self._renderer = FrameRenderer(self._sim.road_edges(), self.config.scenario.lanes)
            else:
                from sumo_rail.sim.map_render import MapRenderer

                self._renderer = MapRenderer(self._sim.lane_shapes(), self.config.scenario.lanes)
        cfg, ego = self.config, self._ego
        traffic = ego.traffic
        # the observation holds distance / r_max, clipped to 1: exactly what the policy saw
        distances = ego.last_observation[:cfg.lidar.beams].astype(np.float64) * cfg.lidar.range_m
        text = FrameText(self._sim.time_s, traffic.ego.speed_mps, traffic.set_point_mps, traffic.ego.lane,
                         cfg.scenario.lanes, "-" if ego.last_action is None else ego.last_action.name,
                         ego.metrics.decisions)
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
