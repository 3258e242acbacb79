"""Benchmark: RAIL training throughput serially, on 1 and 2 workers, and the learner's share of an iteration.

Runs what `sumo-rail train` runs (BC, then RAIL iterations on the default scenario) through `rail.trainer.train`,
with the backend wrapped to time its `run` calls: everything else in an iteration (discriminator steps, rewards,
ARS update, statistics merge) is the learner's overhead. Checkpoint writing is timed on its own. Alternates
serial, 1 and 2 workers over rounds and checks that all give bit-identical parameters. Writes its section of
docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from doc_section import write_section

from sumo_rail.config import Config
from sumo_rail.datasets import sumo_version
from sumo_rail.drivers.policies import load_policy
from sumo_rail.learning.bc import BcSettings
from sumo_rail.learning.rail.discriminator import DiscriminatorSettings
from sumo_rail.learning.rail.iteration import RailSettings
from sumo_rail.learning.rail.trainer import RunSettings, train
from sumo_rail.runners.backends import ProcessPoolBackend, SerialBackend, Task
from sumo_rail.runners.record import record_demonstrations
from sumo_rail.runners.rollout import ExpertDriver


class TimedBackend:
    """A backend whose `run` calls are timed (the rollouts' share of an iteration): a process pool of `workers`,
    or, for 0 workers, the serial backend running the rollouts in this process (the env's single-process rate)."""

    def __init__(self, workers: int) -> None:
        self.pool = ProcessPoolBackend(workers) if workers else SerialBackend()
        self.workers = max(workers, 1)
        self.rollout_seconds: list[float] = []

    def run(self, tasks: Sequence[Task], on_result: Callable[[int, Any], None] | None = None) -> list[Any]:
        start = time.perf_counter()
        results = self.pool.run(tasks, on_result)
        self.rollout_seconds.append(time.perf_counter() - start)
        return results

    def close(self) -> None:
        self.pool.close()


def measure(settings: RunSettings, config: Config, workers: int, iterations: int, folder: Path) -> dict[str, Any]:
    """One run: per-iteration wall, rollout and save times [s] (the first iteration, with worker start-up and
    BC, is left out), env steps, and the final parameters."""
    backend = TimedBackend(workers)
    rows: list[dict[str, Any]] = []
    saved_at: list[float] = []
    with backend.pool:
        train(folder, settings, config, iterations, backend, resume=False,
              on_iteration=lambda row: (rows.append(row), saved_at.append(time.perf_counter())))
    iteration_ends = [row["wall_time_s"] for row in rows]
    # on_iteration runs after the save; the save time is the gap between two iterations not spent iterating
    gaps = np.diff(saved_at) - np.array(iteration_ends[1:])
    policy, _ = load_policy(folder / "policy_latest.npz")
    return {"wall": iteration_ends[1:], "rollouts": backend.rollout_seconds[1:], "save": list(gaps),
            "steps": [row["env_steps"] for row in rows[1:]], "parameters": policy.parameters}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--directions", type=int, default=32)
    parser.add_argument("--iterations", type=int, default=3, help="per run; the first is not timed")
    parser.add_argument("--rounds", type=int, default=2, help="alternating 1-worker / 2-worker rounds")
    parser.add_argument("--demo-episodes", type=int, default=40)
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks.md"))
    args = parser.parse_args()
    config = Config()
    runs: dict[int, list[dict[str, Any]]] = {0: [], 1: [], 2: []}
    with tempfile.TemporaryDirectory() as folder:
        demos = Path(folder) / "demos.parquet"
        with ProcessPoolBackend(2) as pool:
            record_demonstrations(config, ExpertDriver("normal"), "normal", 0, args.demo_episodes, pool, demos)
        settings = RunSettings(str(demos), "mlp", 10, RailSettings(directions=args.directions,
                                                                   top=args.directions // 2),
                               DiscriminatorSettings(), BcSettings(epochs=20))
        for round_ in range(args.rounds):
            for workers in (0, 1, 2):
                runs[workers].append(measure(settings, config, workers, args.iterations,
                                             Path(folder) / f"{workers}_{round_}"))
    identical = all(np.array_equal(run["parameters"], runs[1][0]["parameters"]) for run in runs[0] + runs[1] + runs[2])
    rollouts = 2 * args.directions

    def median(workers: int, key: str) -> float:
        return statistics.median(value for run in runs[workers] for value in run[key])

    stats = {}
    for workers in (0, 1, 2):
        wall, rollout, save = median(workers, "wall"), median(workers, "rollouts"), median(workers, "save")
        steps = statistics.median(step for run in runs[workers] for step in run["steps"])
        stats[workers] = {"wall": wall, "rollout": rollout, "save": save, "rollouts_per_s": rollouts / wall,
                          "steps_per_s": steps / wall, "learner_share": (wall - rollout) / (wall + save),
                          "save_share": save / (wall + save), "steps": steps}
    speed_up = stats[2]["rollouts_per_s"] / stats[1]["rollouts_per_s"]
    single_process_rate = stats[0]["steps"] / stats[0]["rollout"]  # rollouts alone, in this process
    per_worker = stats[2]["steps_per_s"] / 2 / single_process_rate
    rows = "\n".join(
        f"| {w or '0 (serial, in-process)'} | {s['wall']:.1f} | {s['rollout']:.1f} | {s['save']:.2f} | "
        f"{s['rollouts_per_s']:.2f} | {s['steps_per_s']:.0f} | {100 * s['learner_share']:.1f}% | "
        f"{100 * s['save_share']:.1f}% |"
        for w, s in stats.items())
    section = f"""
## RAIL training throughput (issues 4 and 13)

Command: `make bench` (runs `{' '.join(['python', *sys.argv])}`).
Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, SUMO {sumo_version()}.
Default scenario; two-layer policy (10 hidden units) initialised by 20 BC epochs on {args.demo_episodes} expert
episodes; N = {args.directions} directions, b = {args.directions // 2}, so {rollouts} rollouts an iteration
(~{stats[1]['steps']:.0f} decisions). Medians over iterations 2-{args.iterations} of {args.rounds} alternating
rounds (iteration 1 holds BC and worker start-up). "Learner" is everything in an iteration but the rollouts:
discriminator steps, rewards, the ARS update and the statistics merge; "save" is the checkpoint and the files
written after each iteration. The serial row runs the same rollouts in the benchmark's own process, one after
the other: its decisions/s is the environment's single-process rate for exactly these episodes.

| workers | iteration [s] | rollouts [s] | save [s] | rollouts/s | decisions/s | learner share | save share |
|---|---|---|---|---|---|---|---|
{rows}

Speed-up with 2 workers: **{speed_up:.2f}x** (target >= 1.8x); learner overhead at N = {args.directions}:
**{100 * stats[2]['learner_share']:.1f}%** of the iteration on 2 workers (targets <= 10%, and <= 5% in issue 13:
rollouts >= 95% of the wall time). Training throughput per worker on 2 workers (decisions per second
of iteration, over 2) over the single-process rate (the serial run's decisions per second of rollouts,
{single_process_rate:.0f}): **{per_worker:.2f}** (target >= 0.85). The final parameters of all
{3 * args.rounds} runs were {"bit-identical" if identical else "NOT identical"}.
"""
    write_section(args.out, "train", section)


if __name__ == "__main__":
    main()
