"""Instructions per decision, counted by valgrind's callgrind (the machine's load does not move them): the environment's
own (everything but SUMO's steps, its reloads of warm states and one gc.collect) and SUMO's steps in the env's episode,
and raw libsumo stepping of the same episode (bench_env's raw side: the same start and cruise set-point, the same
steps). One keep episode a road (recommended preset, reset seed `--seed`), instrumentation switched on after a warm-up
reset; needs valgrind. Compare two trees by running it with PYTHONPATH at each. Prints a Markdown table.
Usage: `python benchmarks/count_instructions.py [--seed 1000] [--roads exit merge_from_ramp ...]`.
"""

from __future__ import annotations

import argparse
import gc
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from sumo_rail.config import SCENARIO_KINDS, Config

LABELS = {"PROGRAM TOTALS": "total", ":_wrap_simulation_step ": "steps", ":_wrap_simulation_load ": "loads",
          "gcmodule.c:gc_collect_main ": "gc"}


def config_of(kind: str) -> Config:
    return Config.preset("recommended").with_overrides({"scenario": {"kind": kind}})


def instrument() -> None:
    """Switch callgrind's instrumentation on for this process, and keep collections out of the counts."""
    subprocess.run(["callgrind_control", "-i", "on", str(os.getpid())], stdout=subprocess.DEVNULL, check=True)
    gc.collect()
    gc.disable()


def inner_env(kind: str, seed: int) -> int:
    """One keep episode of the env after a warm-up; its decisions."""
    from sumo_rail.sim.env import HighwayEnv

    env = HighwayEnv(config_of(kind))
    env.reset(seed=0)
    for _ in range(3):
        env.step(0)
    instrument()
    env.reset(seed=seed)
    decisions, done = 0, False
    while not done:
        _, _, terminated, truncated, _ = env.step(0)
        decisions += 1
        done = terminated or truncated
    return decisions


def inner_raw(kind: str, seed: int, decisions: int) -> int:
    """The same episode stepped by plain libsumo (instrumented from its first step)."""
    import gymnasium
    import libsumo

    from sumo_rail.sim.ego import CONTEXT_MARGIN_M
    from sumo_rail.sim.simulation import EGO_ID, Simulation
    from sumo_rail.sim.starts import start_ego

    config = config_of(kind)
    sim = Simulation(config.scenario, config.lidar.range_m + CONTEXT_MARGIN_M)
    rng, _ = gymnasium.utils.seeding.np_random(seed)
    start_ego(sim, rng, config, {})
    sim.set_cruise_speed(min(max(libsumo.vehicle.getSpeed(EGO_ID), config.env.v_min_mps), config.env.v_max_mps))
    instrument()
    for _ in range(decisions * config.env.steps_per_decision(config.scenario.step_length_s)):
        libsumo.simulationStep()
    return decisions


def counted(arguments: list[str]) -> tuple[int, dict[str, int]]:
    """Run this script's inner part under callgrind: (decisions, inclusive instructions by `LABELS`)."""
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "callgrind.out"
        run = subprocess.run(["valgrind", "--tool=callgrind", "--instr-atstart=no", f"--callgrind-out-file={out}",
                              sys.executable, __file__, *arguments], capture_output=True, text=True, check=True)
        decisions = int(re.findall(r"^decisions (\d+)$", run.stdout, re.MULTILINE)[-1])
        report = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(out)],
                                capture_output=True, text=True, check=True).stdout
    counts = dict.fromkeys(LABELS.values(), 0)
    for line in report.splitlines():
        for key, label in LABELS.items():
            if key in line and not counts[label]:
                counts[label] = int(line.split()[0].replace(",", ""))
    return decisions, counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument("--roads", nargs="+", default=[kind for kind in SCENARIO_KINDS if kind != "network"])
    parser.add_argument("--inner", nargs=2, metavar=("SIDE", "KIND"), help=argparse.SUPPRESS)
    parser.add_argument("--decisions", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.inner:
        side, kind = args.inner
        decisions = inner_env(kind, args.seed) if side == "env" else inner_raw(kind, args.seed, args.decisions)
        print(f"decisions {decisions}", flush=True)
        os._exit(0)  # no teardown in the counts
    started = time.time()
    print("| road | decisions | env's own [k instr./decision] | SUMO's steps in the env's episode [M] | raw libsumo "
          "stepping [M] |\n|---|---|---|---|---|")
    for kind in args.roads:
        decisions, env = counted(["--inner", "env", kind, "--seed", str(args.seed)])
        _, raw = counted(["--inner", "raw", kind, "--seed", str(args.seed), "--decisions", str(decisions)])
        own = env["total"] - env["steps"] - env["loads"] - env["gc"]
        print(f"| {kind} | {decisions} | {own / decisions / 1e3:.1f} | {env['steps'] / decisions / 1e6:.2f} | "
              f"{(raw['total'] - raw['gc']) / decisions / 1e6:.2f} |", flush=True)
    print(f"({time.time() - started:.0f} s)", file=sys.stderr)


if __name__ == "__main__":
    main()
