"""Benchmark: what the env core's one-ego case costs and saves. `HighwayEnv` is the Gymnasium adapter over the env
core (`ParallelHighwayEnv` with one ego), whose decision period runs `Simulation.advance`, the one-ego loop of the
K-ego period report (`advance_egos`). Three sides on the same reset seeds, whole episodes of the default scenario,
resets included, keeping lane and set-point: the adapter; the core driven directly (the adapter's cost is the
difference); the adapter with the core's K-ego period loop in place of the one-ego one (the one-ego loop's gain).
Rounds alternate the sides; each figure is the median over rounds of decisions per second of this process's CPU
time (wall clock beside). The sides drive the same episodes: the benchmark checks their decisions are equal.
Writes its section of docs/benchmarks.md (between markers).
"""

from __future__ import annotations

import contextlib
import os
import platform
import statistics
from collections.abc import Iterator

from bench_env import env_round
from bench_multi_ego import Pass, multi_round
from doc_section import bench_parser, write_section

from sumo_rail.config import Config
from sumo_rail.datasets import sumo_version
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.parallel_env import ParallelHighwayEnv
from sumo_rail.sim.simulation import EGO_ID, Simulation

SIDES = ("adapter", "core", "adapter, K-ego period loop")


@contextlib.contextmanager
def k_ego_period_loop() -> Iterator[None]:
    """`Simulation.advance` replaced by `advance_egos` of one ego (the same reports, the K-ego loop's cost)."""
    one_ego = Simulation.advance
    Simulation.advance = lambda self, steps, watch=(), vehicle=EGO_ID: self.advance_egos(steps, [vehicle], watch)[0]
    try:
        yield
    finally:
        Simulation.advance = one_ego


def adapter_round(config: Config, seeds: list[int]) -> Pass:
    env = HighwayEnv(config)
    env.reset(seed=0)  # SUMO started and the kernels loaded outside the timing
    elapsed, decisions = env_round(env, seeds, random_actions=False)
    env.close()
    return Pass(elapsed, sum(decisions), sum(decisions), decisions)


def core_round(config: Config, seeds: list[int]) -> Pass:
    env = ParallelHighwayEnv((EGO_ID,), config)
    env.reset(seed=0)
    result = multi_round(env, seeds, random_actions=False)
    env.close()
    return result


def main() -> None:
    args = bench_parser(__doc__, 6, "episodes per side and round", 5, "alternating rounds").parse_args()
    config, seeds = Config(), list(range(1000, 1000 + args.episodes))
    passes: dict[str, list[Pass]] = {side: [] for side in SIDES}
    for _ in range(args.rounds):
        passes["adapter"].append(adapter_round(config, seeds))
        passes["core"].append(core_round(config, seeds))
        with k_ego_period_loop():
            passes["adapter, K-ego period loop"].append(adapter_round(config, seeds))
    episodes = {side: [p.episode_decisions for p in rounds] for side, rounds in passes.items()}
    if len({str(value) for value in episodes.values()}) != 1:
        raise SystemExit(f"the sides drove different episodes: {episodes}")
    cpu = {side: statistics.median(p.decisions / p.elapsed[1] for p in rounds) for side, rounds in passes.items()}
    wall = {side: statistics.median(p.decisions / p.elapsed[0] for p in rounds) for side, rounds in passes.items()}
    rows = "\n".join(f"| {side} | {cpu[side]:.0f} | {cpu[side] / cpu['adapter']:.3f} | {wall[side]:.0f} |"
                     for side in SIDES)
    section = f"""## One ego: the Gymnasium adapter and the one-ego period loop (issue 45)

`.venv/bin/python benchmarks/bench_one_ego.py --episodes {args.episodes} --rounds {args.rounds}` on
{platform.processor() or platform.machine()}, {os.cpu_count()} logical CPUs, SUMO {sumo_version()}; default scenario,
{args.episodes} episodes ({sum(passes['adapter'][0].episode_decisions)} decisions) per side and round, {args.rounds}
alternating rounds, medians; the three sides drove the same episodes (checked).

| side | decisions per core-second | x adapter | decisions per wall-second |
|---|---|---|---|
{rows}

The adapter's cost is its row against the core's; the one-ego period loop's gain is the adapter's row against the
K-ego loop's (`Simulation.advance` against `advance_egos` of one ego, the same reports).
"""
    write_section(args.out, "one_ego", section)


if __name__ == "__main__":
    main()
