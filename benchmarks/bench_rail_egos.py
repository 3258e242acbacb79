"""Benchmark: a RAIL iteration's decisions per core-second with K egos a road (issue 34), whole episodes and
rollouts of a budget of decisions on respawning egos, against the single-ego path, in one run.

Every side runs `iteration.run_iteration` (rollouts, discriminator steps, ARS update) from the same start on a serial
backend, in this process: one core, SUMO included (libsumo). The policy is the benchmark's committed BC (two-layer,
seed 0) in the benchmark's observation setting; the discriminator's expert pairs are a few recorded expert
episodes. The single-ego path runs each rollout as one episode of `HighwayEnv` (`run_episode`), as RAIL did before
issue 34; K = 1 with whole episodes runs the same episodes on the one-ego road and must end on identical
parameters (checked). Sides alternate over rounds; medians over rounds. Writes its section of docs/benchmarks.md.
"""

from __future__ import annotations

import dataclasses
import os
import platform
import statistics
import sys
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from bench_env import clocks
from doc_section import bench_parser, write_section

from sumo_rail.config import Config
from sumo_rail.datasets import sumo_version
from sumo_rail.drivers.policies import load_policy
from sumo_rail.learning.rail.discriminator import Discriminator, DiscriminatorSettings
from sumo_rail.learning.rail.iteration import RailSettings, RolloutTask, TrainingState, Trajectory, run_iteration
from sumo_rail.learning.rail.normalize import RunningStats
from sumo_rail.runners.backends import SerialBackend, Task, WorkerContext
from sumo_rail.runners.record import record_demonstrations
from sumo_rail.runners.rollout import ExpertDriver, run_episode
from sumo_rail.runners.tables import read_demonstrations

POLICY = Path("docs/results/imitation_table/data/bc_mlp_s0/policy_bc.npz")
SIDES = {"single": (1, None), "episodes K=1": (1, None), "episodes K=4": (4, None), "episodes K=8": (8, None),
         "respawning K=1": (1, "budget"), "respawning K=4": (4, "budget"), "respawning K=8": (8, "budget")}
"""Side -> (egos, rollouts: whole episodes or the budget of decisions)."""


@dataclasses.dataclass(frozen=True)
class SingleEgoRollout:
    """One rollout of a one-member `RolloutTask` as one episode of the single-ego `HighwayEnv`."""

    task: RolloutTask

    def run(self, context: WorkerContext) -> list[list[Trajectory]]:
        (index, sign), = self.task.members
        policy = self.task.perturbed(index, sign, self.task.nu)
        result = run_episode(context.env(self.task.config), lambda observation, traffic: policy.act(observation),
                             self.task.episode_seeds[0], record=True)
        assert result.steps is not None
        return [[Trajectory(result.steps["observation"], result.steps["action"].astype(np.int64),
                            bool(result.metrics["collisions"]), int(result.metrics["steps"]))]]


class Backend(SerialBackend):
    """The serial backend; while `single`, it runs RAIL's rollouts on the single-ego env."""

    single = False

    def run(self, tasks: Sequence[Task], on_result: Callable[[int, Any], None] | None = None) -> list[Any]:
        return super().run([SingleEgoRollout(task) if self.single and isinstance(task, RolloutTask) else task
                            for task in tasks], on_result)


@dataclasses.dataclass(frozen=True)
class Warm:
    """Starts the side's env and resets it once, outside the timing."""

    config: Config
    egos: int | None

    def run(self, context: WorkerContext) -> None:
        (context.env(self.config) if self.egos is None else context.parallel_env(self.config, self.egos)).reset(seed=0)


def iteration(side: str, config: Config, settings: RailSettings, demos: Any, backend: Backend,
              ) -> tuple[np.ndarray, int, np.ndarray]:
    """One timed iteration 0 of `side`: (wall, CPU) time [s], decisions, the parameters after it."""
    policy, _ = load_policy(POLICY)
    count = 10**6  # BC's statistics, the policy's own normaliser
    stats = RunningStats(count, policy.observation_mean, np.square(policy.observation_std.astype(np.float64)) * count)
    state = TrainingState.start(policy.parameters, stats, settings)
    discriminator = Discriminator(policy.shape.observation_size, policy.observation_mean, policy.observation_std,
                                  DiscriminatorSettings())
    backend.single = side == "single"
    backend.run([Warm(config, None if backend.single else settings.egos)])
    start = clocks()
    log = run_iteration(state, policy.shape, config, settings, discriminator, demos, backend)
    return clocks() - start, log.env_steps, state.parameters


def main() -> None:
    parser = bench_parser(__doc__, 6, "expert episodes recorded for the discriminator", 3, "alternating rounds")
    parser.add_argument("--directions", type=int, default=32, help="N (2N rollouts an iteration)")
    parser.add_argument("--decisions", type=int, default=171,
                        help="budget of a respawning rollout: the benchmark's RAIL runs' mean decisions a rollout")
    args = parser.parse_args()
    config = Config.from_dict({"observation": {"lane_block": 1}})
    passes: dict[str, list[tuple[np.ndarray, int]]] = {side: [] for side in SIDES}
    ends: dict[str, np.ndarray] = {}
    with tempfile.TemporaryDirectory() as folder, Backend() as backend:
        path = Path(folder) / "demos.parquet"
        record_demonstrations(config, ExpertDriver("normal"), "normal", 0, args.episodes, backend, path)
        demos = read_demonstrations(path, len(load_policy(POLICY)[0].observation_mean))
        for _ in range(args.rounds):
            for side, (egos, budget) in SIDES.items():
                settings = RailSettings(directions=args.directions, egos=egos,
                                        rollout_decisions=args.decisions if budget else None)
                elapsed, decisions, ends[side] = iteration(side, config, settings, demos, backend)
                passes[side].append((elapsed, decisions))
    identical = np.array_equal(ends["single"], ends["episodes K=1"])

    def rate(side: str, clock: int) -> float:
        return statistics.median(decisions / elapsed[clock] for elapsed, decisions in passes[side])
    base = rate("single", 1)
    rows = "\n".join(f"| {side} | {statistics.median(d for _, d in passes[side]):.0f} | {rate(side, 1):.0f} | "
                     f"**{rate(side, 1) / base:.2f}** | {rate(side, 0):.0f} |" for side in SIDES)
    at_8 = rate("respawning K=8", 1) / base
    section = f"""
## A RAIL iteration with K egos a road (issue 34)

Command: `python {' '.join(sys.argv)}` (in `make bench`).
Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, SUMO {sumo_version()};
one process, one core (serial backend, SUMO in-process). Default scenario with the benchmark's lane block; the
policy is the benchmark's BC (`{POLICY}`), N = {args.directions} directions ({2 * args.directions} rollouts), one
iteration 0 per side and round ({args.rounds} alternating rounds, medians), discriminator steps and ARS update
included.

- single: each rollout one episode of the single-ego `HighwayEnv`, RAIL's path before issue 34.
- episodes K: K rollouts a road, each one whole episode (`train --set rail.egos=K`); the road's episode lasts until its
  slowest ego has finished. K = 1 ended on parameters identical to the single side's: **{identical}**.
- respawning K: K rollouts a road, each a budget of {args.decisions} decisions of its ego, respawning whenever an
  episode ends (`train --set rail.egos=K --set rail.rollout_decisions={args.decisions}`), so every ego decides in
  every period.

Respawning egos at K = 8: **{at_8:.2f}x** the single-ego path's decisions per core-second (goal: at least 3.5x).

| side | decisions an iteration | decisions per core-second | x single | decisions per wall-second |
|---|---|---|---|---|
{rows}
"""
    write_section(args.out, "rail_egos", section)


if __name__ == "__main__":
    main()
