"""Benchmark: the full environment vs raw libsumo stepping of the same traffic, resets, and peak memory.

Both sides run the same episodes (same warm state, SUMO seed and ego start, drawn exactly as the env's
reset draws them) for the same simulated time; rounds alternate env and raw so machine noise hits both.
Writes its section of docs/benchmarks.md (between markers) with the command and the machine.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

import gymnasium
import libsumo
import numpy as np
from doc_section import write_section

from sumo_rail.config import Config
from sumo_rail.datasets import sumo_version
from sumo_rail.sim.env import EpisodeStart, HighwayEnv
from sumo_rail.sim.simulation import EGO_ID, Simulation


def env_round(env: HighwayEnv, seeds: list[int], random_actions: bool) -> tuple[float, list[int]]:
    """Wall time of whole episodes (resets included), keeping or random actions; decisions per episode."""
    decisions = []
    start = time.perf_counter()
    for seed in seeds:
        env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        count, done = 0, False
        while not done:
            action = int(rng.integers(5)) if random_actions else 0
            _, _, terminated, truncated, _ = env.step(action)
            count += 1
            done = terminated or truncated
        decisions.append(count)
    return time.perf_counter() - start, decisions


def raw_round(sim: Simulation, config: Config, seeds: list[int],
              decisions: list[int]) -> tuple[float, float, list[int]]:
    """Same starts, plain simulationStep for the same simulated time: (stepping time, reset time, vehicle counts)."""
    steps_per_decision = config.env.steps_per_decision(config.scenario.step_length_s)
    stepping = resetting = 0.0
    vehicles = []
    for seed, count in zip(seeds, decisions, strict=True):
        rng, _ = gymnasium.utils.seeding.np_random(seed)
        start = EpisodeStart.draw(rng, config, sim.snapshot_count)
        t0 = time.perf_counter()
        sim.reset(**dataclasses.asdict(start))
        # the env's initial cruise set-point (kept by a 'keep' driver), so both egos drive alike
        set_point = min(max(libsumo.vehicle.getSpeed(EGO_ID), config.env.v_min_mps), config.env.v_max_mps)
        sim.set_cruise_speed(set_point)
        t1 = time.perf_counter()
        for _ in range(count):
            for _ in range(steps_per_decision):
                libsumo.simulationStep()
        stepping += time.perf_counter() - t1
        resetting += t1 - t0
        vehicles.append(libsumo.vehicle.getIDCount())
    return stepping, resetting, vehicles


def cold_warmup_seconds(config: Config) -> float:
    """Wall time to build warm states from scratch (the cost a reset would have without saved states)."""
    previous = os.environ.get("SUMO_RAIL_CACHE")
    with tempfile.TemporaryDirectory() as cache:
        os.environ["SUMO_RAIL_CACHE"] = cache
        start = time.perf_counter()
        sim = Simulation(dataclasses.replace(config.scenario, snapshots=1), context_radius_m=120.0)
        elapsed = time.perf_counter() - start
        sim.close()
    if previous is None:
        del os.environ["SUMO_RAIL_CACHE"]
    else:
        os.environ["SUMO_RAIL_CACHE"] = previous
    return elapsed


@dataclasses.dataclass(frozen=True)
class Figures:
    """What one scenario's rounds measured (medians over rounds)."""

    vehicles: list[int]
    decisions_per_round: int
    raw_rate: float
    env_rate: float
    random_rate: float
    ratio: float
    reset_ms: float
    peak_rss_mb: float


def measure(config: Config, seeds: list[int], rounds: int) -> Figures:
    """Alternate env and raw rounds on the same episodes; the ratio is the median of per-round ratios."""
    warm = HighwayEnv(config)
    warm.reset(seed=0)  # builds the network and warm states outside the timing
    warm.close()
    env_rates, raw_rates, ratios, random_rates, reset_times, vehicles = [], [], [], [], [], []
    decisions: list[int] = []
    peak_rss_mb = 0.0
    for _ in range(rounds):
        env = HighwayEnv(config)
        elapsed, random_decisions = env_round(env, seeds, random_actions=True)
        random_rates.append(sum(random_decisions) / elapsed)
        env_elapsed, decisions = env_round(env, seeds, random_actions=False)
        peak_rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        env.close()
        sim = Simulation(config.scenario, context_radius_m=config.lidar.range_m + 20.0)
        stepping, resetting, counts = raw_round(sim, config, seeds, decisions)
        sim.close()
        env_rates.append(sum(decisions) / env_elapsed)
        raw_rates.append(sum(decisions) / stepping)
        ratios.append(stepping / env_elapsed)
        reset_times.append(resetting / len(seeds))
        vehicles.extend(counts)
    median = statistics.median
    return Figures(vehicles, sum(decisions), median(raw_rates), median(env_rates), median(random_rates),
                   median(ratios), 1000 * median(reset_times), peak_rss_mb)


def table_rows(label: str, figures: Figures) -> str:
    v = figures.vehicles
    return f"""| {label}: vehicles on the road at episode end (mean, min-max) | \
{statistics.mean(v):.0f} ({min(v)}-{max(v)}) |
| {label}: raw libsumo stepping, same simulated time [decisions/s] | {figures.raw_rate:.0f} |
| {label}: full environment, resets included [decisions/s] (target >= 400 at ~100 vehicles) | \
{figures.env_rate:.0f} |
| {label}: full environment, random driver (more lane changes) [decisions/s] | {figures.random_rate:.0f} |
| {label}: **ratio env / raw** (median of per-round ratios; target >= 0.85) | **{figures.ratio:.2f}** |
| {label}: reset from a saved warm state (reload + ego insertion) [ms] | {figures.reset_ms:.1f} |
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--episodes", type=int, default=6, help="episodes per round")
    parser.add_argument("--rounds", type=int, default=5, help="alternating env/raw rounds")
    parser.add_argument("--light-flow", type=float, default=3000.0,
                        help="flow [veh/h] of the second scenario, chosen for about 100 vehicles on the road")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks.md"))
    args = parser.parse_args()
    default = Config()
    light = default.with_overrides({"scenario": {"flow_veh_per_h": args.light_flow}})
    seeds = list(range(1000, 1000 + args.episodes))
    dense_figures = measure(default, seeds, args.rounds)
    light_figures = measure(light, seeds, args.rounds)
    warmup = cold_warmup_seconds(default)
    scenario, env = default.scenario, default.env
    section = f"""
## Environment vs raw libsumo (issue 2)

Command: `make bench` (runs `{' '.join(['python', *sys.argv])}`).
Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, SUMO {sumo_version()};
one process, one core. Scenario: {scenario.lanes} lanes, {scenario.length_m:.0f} m, decision period
{env.decision_period_s} s ({env.steps_per_decision(scenario.step_length_s)} SUMO steps of {scenario.step_length_s} s);
'default' is the default flow of {scenario.flow_veh_per_h:.0f} veh/h, 'light' is {args.light_flow:.0f} veh/h
(about 100 vehicles on the road). {args.episodes} episodes x {args.rounds} alternating rounds
(~{dense_figures.decisions_per_round} decisions a round), medians reported. The ratio compares like with like: the
env's ego keeps its lane and set-point, exactly as the ego does in the raw run, so SUMO does the same work on
both sides; a random driver's lane changes make SUMO itself slower (continuous lane changes), shown on its own row.

| measure | value |
|---|---|
{table_rows("default", dense_figures)}{table_rows("light", light_figures)}\
| cold warm-up of one state, the alternative to saved states [s] | {warmup:.2f} |
| peak memory of the environment process (max RSS) [MB] (target <= 300) | {dense_figures.peak_rss_mb:.0f} |
"""
    print(section)
    write_section(args.out, "env", section)


if __name__ == "__main__":
    main()
