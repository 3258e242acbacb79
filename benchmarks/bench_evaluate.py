"""Benchmark: what the comparison with the expert costs `evaluate`.

Runs the same episodes (the test pool's warm states, the same seeds) as plain episodes, as `sumo-rail
evaluate` ran them before the comparison existed, and as evaluation tasks that also ask the reference expert at
every decision and keep the per-decision records; one process, alternating rounds, medians. Writes its section of
docs/benchmarks.md.
"""

from __future__ import annotations

import os
import platform
import statistics
import sys
import time

from doc_section import bench_parser, write_section

from sumo_rail.config import Config
from sumo_rail.datasets import sumo_version
from sumo_rail.drivers.expert import DEFAULT_STYLE
from sumo_rail.evaluation.evaluate import Agreement
from sumo_rail.evaluation.protocol import EvaluationTask, RoadStart
from sumo_rail.runners.backends import SerialBackend
from sumo_rail.runners.rollout import EpisodeTask, ExpertDriver, KeepDriver, RandomDriver
from sumo_rail.seeding import Purpose, episode_seeds

DRIVERS = (ExpertDriver(DEFAULT_STYLE), KeepDriver(), RandomDriver())


def main() -> None:
    args = bench_parser(__doc__, 8, "episodes per driver and round", 5,
                        "alternating plain / compared rounds").parse_args()
    config = Config()
    seeds = episode_seeds(Purpose.EVALUATE, 1000, args.episodes)
    plain = [EpisodeTask(config, driver, seed, pool="test", warm_state=k) for driver in DRIVERS
             for k, seed in enumerate(seeds)]
    compared = [EvaluationTask(RoadStart(config, task.pool, task.warm_state), task.driver, task.seed,
                               (Agreement(ExpertDriver(DEFAULT_STYLE)),)) for task in plain]
    rates: dict[str, list[float]] = {"plain": [], "compared": []}
    decisions = 0
    with SerialBackend() as backend:
        backend.run(plain[:1])  # network and warm states, untimed
        for _ in range(args.rounds):
            for name, tasks in (("plain", plain), ("compared", compared)):
                start = time.perf_counter()
                results = backend.run(tasks)
                rates[name].append(len(tasks) / (time.perf_counter() - start))
            decisions = sum(result.metrics["steps"] for result in results)
    ratios = [compared / plain for plain, compared in zip(rates["plain"], rates["compared"], strict=True)]
    plain_rate, compared_rate = statistics.median(rates["plain"]), statistics.median(rates["compared"])
    section = f"""
## What the comparison with the expert costs `evaluate` (issue 12)

Command: `make bench` (runs `{' '.join(['python', *sys.argv])}`).
Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, SUMO {sumo_version()};
one process. Default scenario; drivers expert-{DEFAULT_STYLE}, keep and random, {args.episodes} episodes each
({decisions} decisions a round) from the test pool's warm states; {args.rounds} alternating rounds, medians.

| episodes run as | episodes/s |
|---|---|
| plain episodes (evaluate before the comparison) | {plain_rate:.2f} |
| with the reference expert asked at every decision and the per-decision records | {compared_rate:.2f} |

Cost of the comparison: **{100 * (1 - statistics.median(ratios)):.1f}%** of evaluate's episodes/s (median of the
per-round ratios; target <= 10%).
"""
    write_section(args.out, "evaluate", section)


if __name__ == "__main__":
    main()
