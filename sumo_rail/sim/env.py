"""`HighwayEnv`: the Gymnasium environment, the env core (`sumo_rail.sim.parallel_env.ParallelHighwayEnv`) with
one ego seen through Gymnasium's API: the simulation, LIDAR, actions, rewards, rendering and the GUI are the core's.

Each reset draws, from the env's `np_random`, the warm traffic state, SUMO's seed, the ego's start lane and
position (drawn again where that place has no room, `sumo_rail.sim.starts`), so `reset(seed=s)` followed by the
same actions reproduces the same episode. `reset(options=...)`
may choose the warm-state pool (`"pool"`: "train", the default, "validation" or "test"; see
`sumo_rail.sim.simulation`) and fix the warm state (`"warm_state"`: its index in the pool) instead of drawing it, and
say who drives the ego (`"controller"`: `sumo_rail.sim.controllers`).
One decision lasts `env.decision_period_s`; the reward of a decision is longitudinal + lateral, or
`collision_reward` when the ego collides (the episode then terminates).
Reaching the end of the road or the time limit truncates it.

`config` may be a `Config`, a nested mapping `{"scenario": {"lanes": 3}}` or the path of a TOML file, as
`gymnasium.make(ENV_ID, config=...)` passes it. `render_mode="rgb_array"` makes `render()` return a bird's-eye
frame of the last decision (`sumo_rail.sim.render`); `"human"` drives SUMO in sumo-gui, following the ego.
Unknown reset options are refused (ValueError).
"""

from __future__ import annotations

from collections.abc import Mapping
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np

from sumo_rail.config import Config
from sumo_rail.sim.observers import WatchedObserver
from sumo_rail.sim.parallel_env import RENDER_MODES, ParallelHighwayEnv
from sumo_rail.sim.rewards import EpisodeMetrics
from sumo_rail.sim.simulation import EGO_ID, Simulation
from sumo_rail.sim.starts import StartRule
from sumo_rail.sim.traffic import TrafficView

__all__ = ["RENDER_MODES", "HighwayEnv", "TrafficView"]


class HighwayEnv(gymnasium.Env[np.ndarray, np.int64]):
    """Five-lane SUMO highway with a 24-beam LIDAR and five high-level actions: the env core's one ego (SUMO vehicle
    `EGO_ID`). `transport`, `render_mode`, `gui_delay_ms` and `start` are the core's (`ParallelHighwayEnv`):
    libsumo or traci ("auto" takes libsumo unless another env of this process holds it), sumo-gui's wall time per
    SUMO step [ms] (100: real time at 0.1 s steps), how episodes start (default: warm traffic states)."""

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 2}  # noqa: RUF012 - Gymnasium's class attribute

    def __init__(self, config: Config | Mapping[str, Any] | str | Path | None = None, render_mode: str | None = None,
                 transport: str = "auto", gui_delay_ms: float = 100.0, start: StartRule | None = None) -> None:
        self.core = ParallelHighwayEnv((EGO_ID,), config, transport, render_mode, gui_delay_ms, start)
        self.config, self.transport, self.render_mode = self.core.config, transport, render_mode
        self.gui_delay_ms = self.core.gui_delay_ms
        # one frame per decision: videos play in real time
        self.metadata = {**self.metadata, "render_fps": 1.0 / self.config.env.decision_period_s}
        self.observation_space = self.core.observation_space(EGO_ID)
        self.action_space = self.core.action_space(EGO_ID)

    @property
    def np_random(self) -> np.random.Generator:
        """The generator every reset draws from: the core's (seeded by `reset(seed=...)`, Gymnasium's seeding), so an
        episode the core runs itself (`sumo_rail.runners.rollout.run_episode`) draws as one reset here."""
        return self.core.np_random

    @np_random.setter
    def np_random(self, generator: np.random.Generator) -> None:
        self.core.np_random = generator

    @property
    def simulation(self) -> Simulation | None:
        """The SUMO simulation (None before the first reset and after `close`)."""
        return self.core.simulation

    @property
    def metrics(self) -> EpisodeMetrics:
        """Totals of the current episode."""
        return self.core.metrics(EGO_ID) if self.core.started else EpisodeMetrics()

    @property
    def traffic(self) -> TrafficView:
        """The ego and its neighbours at the last decision (read directly from SUMO, not from the LIDAR)."""
        if not self.core.started:
            raise RuntimeError("call reset() before reading the traffic")
        return self.core.traffic(EGO_ID)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None,
              ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)  # Gymnasium's seeding, for its own records (np_random_seed)
        known = self.core.options
        unknown = sorted(set(options or {}) - set(known))
        if unknown:  # the core ignores them (PettingZoo's API test passes one); a Gymnasium user meant something
            raise ValueError(f"unknown reset options {unknown}; known: {', '.join(map(repr, known))}")
        observations, infos = self.core.reset(seed=seed, options=options)  # the same seeding: one generator, the core's
        return observations[EGO_ID], infos[EGO_ID]

    def step(self, action: int | np.integer) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if not self.core.started:
            raise RuntimeError("call reset() before step()")
        observations, rewards, terminations, truncations, infos = self.core.step({EGO_ID: action})
        return (observations[EGO_ID], rewards[EGO_ID], terminations[EGO_ID], truncations[EGO_ID],
                infos[EGO_ID])

    def watching(self, observer: WatchedObserver) -> AbstractContextManager[WatchedObserver]:
        """The core's `watching`: `observer` is shown every SUMO step or each reset and decision within the block."""
        return self.core.watching(observer)

    def render(self) -> np.ndarray | None:
        """With render_mode "rgb_array", the bird's-eye frame of the last decision (`frame()`); with "human",
        sumo-gui draws by itself and this returns None."""
        return self.core.render()

    def frame(self) -> np.ndarray:
        """A bird's-eye RGB frame of the last decision, shape (H, W, 3) uint8, whatever the render mode: the road,
        every vehicle in LIDAR range coloured by type, the ego, its LIDAR beams and hits, and its speed,
        set-point, lane and last action."""
        return self.core.frame(EGO_ID)

    def gui_screenshot(self, path: str | Path, width_px: int = 1280, height_px: int = 800) -> None:
        """With render_mode "human": save sumo-gui's view as a PNG at `path` when the next step is drawn."""
        self.core.gui_screenshot(path, width_px, height_px)

    def close(self) -> None:
        self.core.close()  # the last episode's traffic and metrics stay readable
        super().close()
