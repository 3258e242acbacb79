"""Benchmark: the acceleration interface against raw libsumo stepping of the same episodes, at decision periods down
to SUMO's step (issue 53). `bench_env.measure` on each setting: the env with the interface's keep action (an
acceleration of 0 in the lane) and raw `simulationStep` of the same starts for the same simulated time, alternating
rounds, medians of per-round ratios, on the wall and the process CPU clock. The paper's five actions at 0.1 s are
the row beside it (the same decision loop, the set-point commands in place of `setAcceleration`). Writes its section
of docs/benchmarks.md (between markers).
"""

from __future__ import annotations

import os
import platform

from bench_env import Figures, measure
from doc_section import bench_parser, write_section

from sumo_rail.config import Config
from sumo_rail.datasets import sumo_version

SETTINGS = {"acceleration, 0.5 s": ("acceleration", 0.5), "acceleration, 0.1 s": ("acceleration", 0.1),
            "paper, 0.1 s": ("paper", 0.1)}
"""Row label -> (actions.interface, env.decision_period_s)."""


def row(label: str, figures: Figures) -> str:
    return (f"| {label} | {figures.decisions_per_round} | {figures.raw_rate:.0f} | {figures.env_rate:.0f} | "
            f"**{figures.ratio:.2f}** | {figures.ratio_cpu:.2f} | {figures.ratio_cpu_with_resets:.2f} |")


def main() -> None:
    args = bench_parser(__doc__, 3, "episodes per round", 3, "alternating env/raw rounds").parse_args()
    seeds = list(range(1000, 1000 + args.episodes))
    rows = []
    for label, (interface, period_s) in SETTINGS.items():
        config = Config().with_overrides({"actions": {"interface": interface},
                                          "env": {"decision_period_s": period_s}})
        rows.append(row(label, measure(config, seeds, args.rounds)))
    load = os.getloadavg()[0]
    scenario = Config().scenario
    section = f"""## The acceleration interface at SUMO's step vs raw libsumo (issue 53)

`.venv/bin/python benchmarks/bench_acceleration.py --episodes {args.episodes} --rounds {args.rounds}` on
{platform.machine()}, {os.cpu_count()} logical CPUs, Python {platform.python_version()}, SUMO {sumo_version()}; the
default scenario ({scenario.lanes} lanes, {scenario.flow_veh_per_h:.0f} veh/h), {args.episodes} episodes per round
and side, {args.rounds} alternating rounds, medians. The env's ego takes the interface's keep action (acceleration 0,
or the paper's keep); the raw side starts the same ego and steps SUMO for the same simulated time. Ratio: raw
stepping time over the env's time, the env's resets counted on its side (as in "Environment vs raw libsumo").
The machine's load average at the end: {load:.1f} (above the core count, other jobs shared the cores: the CPU-clock
ratios are the steadier ones). At 0.1 s a decision is one SUMO step, so the env's fixed work per decision (the
observation, the command, the safety readings) weighs five times as much against SUMO's as at 0.5 s.

| setting | decisions a round | raw [1/s] | env [1/s] | env / raw (wall) | (CPU) | (CPU, both resets) |
|---|---|---|---|---|---|---|
{chr(10).join(rows)}
"""
    write_section(args.out, "acceleration", section)


if __name__ == "__main__":
    main()
