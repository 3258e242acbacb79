"""Benchmark: the environment against raw libsumo stepping of the same episodes on every road (scenario.kind), as
bench_env measures the straight road: the same starts, the same simulated time, env and raw rounds alternating,
medians of per-round ratios on the wall and process CPU clocks. The headline ratio counts both sides' resets (the
same reloads of warm states); the ratio that counts only the env's is kept beside it. Writes its section of
docs/benchmarks.md."""

from __future__ import annotations

import os
import platform
import statistics
import sys

from bench_env import measure
from doc_section import bench_parser, write_section

from sumo_rail.config import SCENARIO_KINDS, Config
from sumo_rail.datasets import sumo_version

HEADER = ("| road | vehicles at episode end | raw libsumo [decisions/s] | environment [decisions/s] "
          "| **ratio env / raw** | ratio, CPU clock | ratio, raw resets not counted | the same, CPU clock "
          "| reset [ms] |\n"
          "|---|---|---|---|---|---|---|---|---|")


def main() -> None:
    args = bench_parser(__doc__, 4, "episodes per round", 3, "alternating env/raw rounds").parse_args()
    seeds = list(range(1000, 1000 + args.episodes))
    rows = []
    for kind in [kind for kind in SCENARIO_KINDS if kind != "network"]:
        config = Config.preset("recommended").with_overrides({"scenario": {"kind": kind}})
        figures = measure(config, seeds, args.rounds)
        rows.append(f"| {kind} | {statistics.mean(figures.vehicles):.0f} | {figures.raw_rate_with_resets:.0f} | "
                    f"{figures.env_rate:.0f} | **{figures.ratio_with_resets:.2f}** | "
                    f"{figures.ratio_cpu_with_resets:.2f} | {figures.ratio:.2f} | {figures.ratio_cpu:.2f} | "
                    f"{figures.reset_ms:.1f} |")
        print(rows[-1], flush=True)
    table = "\n".join(rows)
    section = f"""
## Every road: the environment vs raw libsumo (issue 35)

Command: `make bench` (runs `{' '.join(['python', *sys.argv])}`).
Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, SUMO {sumo_version()};
one process. Each road in the recommended setting (LIDAR, lane-wise and route blocks) at its default traffic;
{args.episodes} episodes x {args.rounds} alternating rounds, the env's ego keeping its lane and set-point (on a road
with a feature it may stop at a lane's end, and its episode then ends: the raw side steps the same time), medians of
per-round ratios (bench_env's method; goal >= 0.85 on each road). Both sides' rates and the headline ratio count
each side's resets: an episode starts, raw or not, by reloading a warm state and inserting the ego, so the ratio
compares like with like (until issue 35's speed rounds the headline counted the env's resets only, a floor of
about 0.92 however cheap a decision; that ratio is kept in the columns "raw resets not counted").

{HEADER}
{table}
"""
    write_section(args.out, "roads", section)


if __name__ == "__main__":
    main()
