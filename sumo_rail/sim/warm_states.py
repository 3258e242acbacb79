"""Warm traffic states: episodes start from a saved state of flowing traffic instead of an empty road.

They come in three pools that never share a state: "train" (recording, training rollouts and plain Gymnasium use),
"validation" (validation during training) and "test" (`evaluate`). Each pool is one warm-up run with its own
traffic seed (`scenario.traffic_seed` + the pool's index) that saves `scenario.snapshots` states, cached on disk
(`network.cache_dir`) and shared by every process: a lock file makes concurrent processes wait for the one that
builds them, and a damaged state (`network.warm_state_problem`) has its pool built again. The warm-up itself
drives SUMO, so the simulation runs it (`WarmStates.run_warm_up`).
"""

from __future__ import annotations

import fcntl
import logging
from collections.abc import Callable
from pathlib import Path

from sumo_rail.config import ScenarioConfig
from sumo_rail.sim import network

log = logging.getLogger(__name__)

WARM_STATE_POOLS = ("train", "validation", "test")
"""Disjoint sets of warm traffic states, by what the episodes are for."""


class WarmStates:
    """The warm states of one scenario's pools as file paths, each pool checked (and built if need be) on first use.

    `options` are the SUMO options that shape the traffic (part of the cache key); `run_warm_up(traffic_seed,
    paths)` runs a warm-up and saves its states to `paths`."""

    def __init__(self, scenario: ScenarioConfig, built: network.BuiltNetwork, options: list[str],
                 run_warm_up: Callable[[int, list[Path]], None]) -> None:
        self.scenario, self.built, self.options, self.run_warm_up = scenario, built, options, run_warm_up
        self._pools: dict[str, list[Path]] = {}

    def pool(self, name: str) -> list[Path]:
        """Paths of the warm states of pool `name`, built on first use."""
        if name not in self._pools:
            if name not in WARM_STATE_POOLS:
                raise ValueError(f"warm-state pool must be one of {', '.join(WARM_STATE_POOLS)}, got {name!r}")
            self._pools[name] = self._cached(self.scenario.traffic_seed + WARM_STATE_POOLS.index(name))
        return self._pools[name]

    def forget(self) -> None:
        """Check the files again at the next `pool` (after one was found damaged)."""
        self._pools.clear()

    def _cached(self, traffic_seed: int) -> list[Path]:
        """Paths of the warm states of one warm-up run, running it first when they are not cached yet or damaged;
        a lock file makes concurrent processes wait for the one that builds them."""
        directory = network.cache_dir() / "states" / network.warm_state_key(self.scenario, self.built, self.options,
                                                                           traffic_seed)
        paths = [directory / f"state_{k:03d}.xml" for k in range(self.scenario.snapshots)]
        if not self._problems(paths):
            return paths
        directory.mkdir(parents=True, exist_ok=True)
        with open(directory / ".lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            problems = self._problems(paths)
            if problems:
                if any(path.exists() for path in paths):
                    log.warning("cached warm states in %s are damaged (%s); running the warm-up again", directory,
                                problems[0])
                self.run_warm_up(traffic_seed, paths)
        return paths

    def _problems(self, paths: list[Path]) -> list[str]:
        problems = (network.warm_state_problem(path, k, self.scenario) for k, path in enumerate(paths))
        return [problem for problem in problems if problem is not None]
