"""Benchmark: what the Gymnasium adapter costs. `HighwayEnv` is the adapter over the env core (`ParallelHighwayEnv`
with one ego). Two sides on the same reset seeds, whole episodes of the default scenario, resets included, keeping
lane and set-point: the adapter, and the core driven directly. Rounds alternate the sides; each figure is the
median over rounds of decisions per second of this process's CPU time (wall clock beside). The sides drive the
same episodes: the benchmark checks their decisions are equal. Writes its section of docs/benchmarks.md (between
markers).
"""

from __future__ import annotations

import os
import platform
import statistics

from bench_env import env_round
from bench_multi_ego import Pass, multi_round
from doc_section import bench_parser, write_section

from sumo_rail.config import Config
from sumo_rail.datasets import sumo_version
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.parallel_env import ParallelHighwayEnv
from sumo_rail.sim.simulation import EGO_ID

SIDES = ("adapter", "core")


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
    episodes = {side: [p.episode_decisions for p in rounds] for side, rounds in passes.items()}
    if len({str(value) for value in episodes.values()}) != 1:
        raise SystemExit(f"the sides drove different episodes: {episodes}")
    cpu = {side: statistics.median(p.decisions / p.elapsed[1] for p in rounds) for side, rounds in passes.items()}
    wall = {side: statistics.median(p.decisions / p.elapsed[0] for p in rounds) for side, rounds in passes.items()}
    rows = "\n".join(f"| {side} | {cpu[side]:.0f} | {cpu[side] / cpu['adapter']:.3f} | {wall[side]:.0f} |"
                     for side in SIDES)
    section = f"""## One ego: the Gymnasium adapter over the env core (issue 45)

`.venv/bin/python benchmarks/bench_one_ego.py --episodes {args.episodes} --rounds {args.rounds}` on
{platform.processor() or platform.machine()}, {os.cpu_count()} logical CPUs, SUMO {sumo_version()}; default scenario,
{args.episodes} episodes ({sum(passes['adapter'][0].episode_decisions)} decisions) per side and round, {args.rounds}
alternating rounds, medians; the two sides drove the same episodes (checked).

| side | decisions per core-second | x adapter | decisions per wall-second |
|---|---|---|---|
{rows}

The adapter's cost is its row against the core's. The core had a period loop of its own for one ego
(`Simulation.advance`) until this benchmark measured it, at 58935b6 (`.venv/bin/python benchmarks/bench_one_ego.py
--episodes 6 --rounds 9`, a third side running `advance_egos` for one ego): 482 decisions per core-second with it,
498 without (1.033x; 5 rounds: 429 and 424), no gain beyond noise, so it was removed.
"""
    write_section(args.out, "one_ego", section)


if __name__ == "__main__":
    main()
