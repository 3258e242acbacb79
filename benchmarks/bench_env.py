"""Benchmark: the full environment vs raw libsumo stepping of the same traffic, resets, and peak memory.

Both sides run the same episodes (same warm state, SUMO seed and ego start, drawn exactly as the env's
reset draws them) for the same simulated time; rounds alternate env and raw so machine noise hits both.
Every interval is timed on the wall clock and on the process's CPU clock: on a shared machine the CPU clock is
less disturbed by other processes (it still sees their effect on the caches). Writes its section of
docs/benchmarks.md (between markers) with the command and the machine.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import resource
import statistics
import subprocess
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
from sumo_rail.sim.actions import keep_action
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.simulation import EGO_ID, Simulation
from sumo_rail.sim.starts import start_ego


def clocks() -> np.ndarray:
    """(wall, process CPU) time [s]."""
    return np.array([time.perf_counter(), time.process_time()])


def env_round(env: HighwayEnv, seeds: list[int], random_actions: bool) -> tuple[np.ndarray, list[int]]:
    """(wall, CPU) time of whole episodes (resets included), keeping (the interface's action that changes nothing) or
    random actions; decisions per episode."""
    keep = keep_action(env.config.actions)
    decisions = []
    start = clocks()
    for seed in seeds:
        env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        count, done = 0, False
        while not done:
            action = int(rng.integers(env.action_space.n)) if random_actions else keep
            _, _, terminated, truncated, _ = env.step(action)
            count += 1
            done = terminated or truncated
        decisions.append(count)
    return clocks() - start, decisions


def raw_round(sim: Simulation, config: Config, seeds: list[int],
              decisions: list[int]) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """Same starts, plain simulationStep for the same simulated time: ((wall, CPU) stepping time, the same for
    resets, vehicle counts)."""
    steps_per_decision = config.env.steps_per_decision(config.scenario.step_length_s)
    stepping, resetting = np.zeros(2), np.zeros(2)
    vehicles = []
    for seed, count in zip(seeds, decisions, strict=True):
        rng, _ = gymnasium.utils.seeding.np_random(seed)
        t0 = clocks()
        start_ego(sim, rng, config, {})
        # the env's initial cruise set-point (kept by a 'keep' driver), so both egos drive alike
        set_point = min(max(libsumo.vehicle.getSpeed(EGO_ID), config.env.v_min_mps), config.env.v_max_mps)
        sim.set_cruise_speed(set_point)
        t1 = clocks()
        for _ in range(count):
            for _ in range(steps_per_decision):
                libsumo.simulationStep()
        stepping += clocks() - t1
        resetting += t1 - t0
        vehicles.append(libsumo.vehicle.getIDCount())
    return stepping, resetting, vehicles


def untimed_first_reset(sim: Simulation, config: Config, seed: int) -> None:
    """One reset outside the timing, as the env's timed 'keep' round comes after its random round: a simulation's
    first reset checks its pool's warm-state files (parses every one), which would otherwise be timed as a reset of
    the raw side."""
    rng, _ = gymnasium.utils.seeding.np_random(seed)
    start_ego(sim, rng, config, {})


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
    """Raw stepping time over the env's time, resets included on the env's side only (wall clock)."""
    ratio_cpu: float
    """The same on the process CPU clock."""
    ratio_with_resets: float
    """Raw stepping plus the raw side's own resets (the same reloads) over the env's time (wall clock): like with
    like, both sides' resets counted."""
    ratio_cpu_with_resets: float
    """The same on the process CPU clock."""
    raw_rate_with_resets: float
    """Raw decisions per second [1/s], the raw side's resets counted (as the env's rate counts the env's)."""
    reset_ms: float
    peak_rss_mb: float


def measure(config: Config, seeds: list[int], rounds: int) -> Figures:
    """Alternate env and raw rounds on the same episodes; ratios are medians of per-round ratios."""
    warm = HighwayEnv(config)
    warm.reset(seed=0)  # builds the network and warm states outside the timing
    warm.close()
    rows: list[dict[str, float]] = []
    vehicles: list[int] = []
    decisions: list[int] = []
    peak_rss_mb = 0.0
    for _ in range(rounds):
        env = HighwayEnv(config)
        elapsed, random_decisions = env_round(env, seeds, random_actions=True)
        env_elapsed, decisions = env_round(env, seeds, random_actions=False)
        peak_rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        env.close()
        sim = Simulation(config.scenario, context_radius_m=config.lidar.range_m + 20.0)
        untimed_first_reset(sim, config, seeds[0])
        stepping, resetting, counts = raw_round(sim, config, seeds, decisions)
        sim.close()
        rows.append({"random": sum(random_decisions) / elapsed[0], "env": sum(decisions) / env_elapsed[0],
                     "raw": sum(decisions) / stepping[0], "ratio": stepping[0] / env_elapsed[0],
                     "ratio_cpu": stepping[1] / env_elapsed[1],
                     "ratio_with_resets": (stepping[0] + resetting[0]) / env_elapsed[0],
                     "ratio_cpu_with_resets": (stepping[1] + resetting[1]) / env_elapsed[1],
                     "raw_with_resets": sum(decisions) / (stepping[0] + resetting[0]),
                     "reset": resetting[0] / len(seeds)})
        vehicles.extend(counts)

    def median(key: str) -> float:
        return statistics.median(row[key] for row in rows)

    return Figures(vehicles, sum(decisions), median("raw"), median("env"), median("random"), median("ratio"),
                   median("ratio_cpu"), median("ratio_with_resets"), median("ratio_cpu_with_resets"),
                   median("raw_with_resets"), 1000 * median("reset"), peak_rss_mb)


_FIRST_RESET = """
import json, time
start = time.perf_counter()
from sumo_rail.config import Config
from sumo_rail.sim.env import HighwayEnv
imported = time.perf_counter()
env = HighwayEnv(Config())
env.reset(seed=0)
reset = time.perf_counter()
env.step(0)
stepped = time.perf_counter()
env.close()
print(json.dumps({"import": imported - start, "reset": reset - imported, "step": stepped - reset}))
"""


def first_reset_seconds(runs: int) -> dict[str, float]:
    """Medians over fresh processes (network, warm states and compiled kernels cached): importing the env, its
    first reset (SUMO started, kernels loaded) and its first step [s]."""
    results = [json.loads(subprocess.run([sys.executable, "-c", _FIRST_RESET], check=True, capture_output=True,
                                         text=True).stdout) for _ in range(runs)]
    return {key: statistics.median(result[key] for result in results) for key in results[0]}


def table_rows(label: str, figures: Figures) -> str:
    v = figures.vehicles
    return f"""| {label}: vehicles on the road at episode end (mean, min-max) | \
{statistics.mean(v):.0f} ({min(v)}-{max(v)}) |
| {label}: raw libsumo stepping, same simulated time [decisions/s] | {figures.raw_rate:.0f} |
| {label}: full environment, resets included [decisions/s] (target >= 400 at ~100 vehicles) | \
{figures.env_rate:.0f} |
| {label}: full environment, random driver (more lane changes) [decisions/s] | {figures.random_rate:.0f} |
| {label}: **ratio env / raw** (median of per-round ratios; target >= 0.90) | **{figures.ratio:.2f}** |
| {label}: ratio env / raw on the process CPU clock | {figures.ratio_cpu:.2f} |
| {label}: ratio env / raw with the raw run's own resets counted too | {figures.ratio_with_resets:.2f} |
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
    first = first_reset_seconds(3)
    scenario, env = default.scenario, default.env
    section = f"""
## Environment vs raw libsumo (issues 2 and 13)

Command: `make bench` (runs `{' '.join(['python', *sys.argv])}`).
Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, SUMO {sumo_version()};
one process, one core. Scenario: {scenario.lanes} lanes, {scenario.length_m:.0f} m, decision period
{env.decision_period_s} s ({env.steps_per_decision(scenario.step_length_s)} SUMO steps of {scenario.step_length_s} s);
'default' is the default flow of {scenario.flow_veh_per_h:.0f} veh/h, 'light' is {args.light_flow:.0f} veh/h
(about 100 vehicles on the road). {args.episodes} episodes x {args.rounds} alternating rounds
(~{dense_figures.decisions_per_round} decisions a round), medians reported. The ratio compares like with like: the
env's ego keeps its lane and set-point, exactly as the ego does in the raw run, so SUMO does the same work on
both sides; a random driver's lane changes make SUMO itself slower (continuous lane changes), shown on its own row.
The raw side's resets (the same reloads of warm states) are timed apart and left out of the ratio, so the
env's resets count as its overhead; the row "with the raw run's own resets" counts them on both sides.

| measure | value |
|---|---|
{table_rows("default", dense_figures)}{table_rows("light", light_figures)}\
| cold warm-up of one state, the alternative to saved states [s] | {warmup:.2f} |
| peak memory of the environment process (max RSS) [MB] (target <= 300) | {dense_figures.peak_rss_mb:.0f} |
| fresh process (network, warm states and compiled kernels cached): import the env [s] | {first["import"]:.2f} |
| fresh process: first reset (SUMO started, kernels loaded) [s] | {first["reset"]:.2f} |
| fresh process: first step after it [ms] | {1000 * first["step"]:.1f} |
"""
    write_section(args.out, "env", section)


if __name__ == "__main__":
    main()
