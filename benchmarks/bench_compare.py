"""Benchmark: the environment side by side with its alternatives, and a projection of one large RAIL iteration.

1. the env on libsumo vs the same env on TraCI over a socket (same episodes, 'keep' driver);
2. simulated seconds per wall second of the env vs highway-env's `highway-v0` with as many vehicles, 5 lanes and
   1 Hz decisions, both with a constant keep/IDLE action;
3. RAIL rollouts/s on the process pool vs Ray with 1 and 2 local workers (worker start-up timed on its own);
4. a projection of one N = 512 iteration (1024 rollouts) on 1 to 64 cores from the measured cost of a rollout
   and the measured learner time of such an iteration.
Rounds alternate the two sides of each comparison so machine noise hits both; medians are reported. Writes its
section of docs/benchmarks.md (between markers) with the command and the machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import libsumo
import numpy as np
from doc_section import write_section

from sumo_rail.config import Config
from sumo_rail.datasets import sumo_version
from sumo_rail.drivers.policies import PolicyShape
from sumo_rail.learning.rail.ars import NoiseAdaptation
from sumo_rail.learning.rail.discriminator import Discriminator, DiscriminatorSettings
from sumo_rail.learning.rail.iteration import RailSettings, RolloutTask, TrainingState, Trajectory, run_iteration
from sumo_rail.learning.rail.normalize import RunningStats
from sumo_rail.runners.backends import ProcessPoolBackend, RolloutBackend, WorkerContext
from sumo_rail.runners.rollout import KeepDriver, run_episode
from sumo_rail.runners.tables import Demonstrations
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.observation import observation_names
from sumo_rail.sim.simulation import TRANSPORTS

median = statistics.median


def keep_round(env: HighwayEnv, seeds: Sequence[int]) -> tuple[float, int, float]:
    """Whole episodes of the 'keep' driver, resets included: (wall time [s], decisions, simulated time [s])."""
    decisions, simulated_s = 0, 0.0
    start = time.perf_counter()
    for seed in seeds:
        metrics = run_episode(env, KeepDriver().create(env.config, seed), seed).metrics
        decisions += metrics["steps"]
        simulated_s += metrics["simulated_s"]
    return time.perf_counter() - start, decisions, simulated_s


def compare_transports(config: Config, seeds: Sequence[int], rounds: int) -> dict[str, Any]:
    """Alternating libsumo / traci rounds of the same episodes: decisions/s of each, median ratio of rates."""
    envs = {transport: HighwayEnv(config, transport=transport) for transport in TRANSPORTS}
    rates: dict[str, list[float]] = {transport: [] for transport in TRANSPORTS}
    decisions: dict[str, int] = {}
    try:
        for env in envs.values():
            env.reset(seed=0)  # starts SUMO outside the timing
        for _ in range(rounds):
            for transport, env in envs.items():
                elapsed, decisions[transport], _ = keep_round(env, seeds)
                rates[transport].append(decisions[transport] / elapsed)
    finally:
        for env in envs.values():
            env.close()
    ratios = [fast / slow for fast, slow in zip(rates["libsumo"], rates["traci"], strict=True)]
    return {"rates": {t: median(r) for t, r in rates.items()}, "ratio": median(ratios),
            "decisions": decisions["libsumo"], "same": decisions["libsumo"] == decisions["traci"]}


def highway_env_round(env: Any, idle: int, seconds: int, seed: int) -> float:
    """Wall time [s] of `seconds` decisions of 1 s with the IDLE action, resetting when an episode ends (resets
    included)."""
    start = time.perf_counter()
    env.reset(seed=seed)
    for step in range(seconds):
        _, _, terminated, truncated, _ = env.step(idle)
        if terminated or truncated:
            env.reset(seed=seed + step + 1)
    return time.perf_counter() - start


def compare_highway_env(config: Config, seeds: Sequence[int], rounds: int, seconds: int,
                        vehicles: int | None) -> dict[str, Any]:
    """Simulated s per wall s of our env (1 s decisions) and highway-env's highway-v0 with as many vehicles (ours,
    counted after each reset, unless `vehicles` is given), in alternating rounds; `error` if it is missing."""
    ours = HighwayEnv(config)
    counts = []
    for seed in seeds:
        ours.reset(seed=seed)
        counts.append(libsumo.vehicle.getIDCount())  # the ego included, as in highway-env's road.vehicles
    result: dict[str, Any] = {"ours_vehicles": statistics.mean(counts)}
    try:
        import gymnasium
        import highway_env
    except ImportError as error:
        ours.close()
        return result | {"error": f"highway-env could not be imported ({error}); `make bench` installs it"}
    gymnasium.register_envs(highway_env)
    target = vehicles or round(result["ours_vehicles"])
    theirs = gymnasium.make("highway-v0", config={"lanes_count": 5, "vehicles_count": target - 1,
                                                  "policy_frequency": 1, "simulation_frequency": 15})
    theirs.reset(seed=0)
    result |= {"theirs_vehicles": len(theirs.unwrapped.road.vehicles), "version": highway_env_version(),
               "simulation_frequency": theirs.unwrapped.config["simulation_frequency"]}
    idle = theirs.unwrapped.action_type.actions_indexes["IDLE"]
    ours_rates, theirs_rates = [], []
    try:
        for round_ in range(rounds):
            elapsed, _, simulated_s = keep_round(ours, seeds)
            ours_rates.append(simulated_s / elapsed)
            theirs_rates.append(seconds / highway_env_round(theirs, idle, seconds, 1000 * round_))
    finally:
        ours.close()
        theirs.close()
    ratios = [a / b for a, b in zip(ours_rates, theirs_rates, strict=True)]
    return result | {"ours": median(ours_rates), "theirs": median(theirs_rates), "ratio": median(ratios)}


def highway_env_version() -> str:
    import importlib.metadata

    return importlib.metadata.version("highway-env")


@dataclass(frozen=True)
class Started:
    """Warm-up task: makes the worker's env and resets it once (SUMO started); returns the worker's pid."""

    config: Config

    def run(self, context: WorkerContext) -> int:
        context.parallel_env(self.config, 1).reset(seed=0)
        return os.getpid()


def start_backend(make: Callable[[int], RolloutBackend], workers: int, config: Config) -> tuple[RolloutBackend, float]:
    """A backend whose every worker has its env running, and the wall time that took [s]."""
    start = time.perf_counter()
    backend = make(workers)
    pids: set[int] = set()
    try:
        for _ in range(10):  # a worker that starts first may take every warm-up task: repeat until all have started
            pids |= set(backend.run([Started(config)] * workers))
            if len(pids) >= workers:
                break
    except BaseException:
        backend.close()
        raise
    return backend, time.perf_counter() - start


def rollout_tasks(config: Config, rollouts: int) -> list[RolloutTask]:
    """RAIL rollout tasks as `run_iteration` builds them (iteration 0, both signs of rollouts / 2 directions)
    for a zero-parameter mlp policy: each rollout drives theta = nu * (+-delta_k)."""
    size = len(observation_names(config))
    shape = PolicyShape("mlp", size)
    parameters = np.zeros(shape.parameter_count, dtype=np.float32)
    seeds = episode_seeds(Purpose.TRAIN, 0, rollouts // 2)
    nu = NoiseAdaptation().initial
    return [RolloutTask(config, shape, parameters, np.zeros(size), np.ones(size), 0, 0, ((k, sign),), nu, (seeds[k],))
            for k in range(rollouts // 2) for sign in (1, -1)]


def ray_backend(workers: int) -> RolloutBackend:
    from sumo_rail.runners.ray_backend import RayBackend

    return RayBackend(workers)


def compare_backends(config: Config, tasks: list[RolloutTask], rounds: int) -> dict[str, Any]:
    """Per backend and worker count: start-up [s], median wall time of the tasks [s]; Ray's median overhead; the
    trajectories; whether both backends returned identical trajectories; why Ray is not available, if it is not."""
    makers: dict[str, Callable[[int], RolloutBackend]] = {"process pool": ProcessPoolBackend, "ray": ray_backend}
    figures: dict[str, Any] = {"startup": {}, "wall": {}, "overhead": {}, "identical": True, "ray_error": None}
    trajectories: dict[str, list[Trajectory]] = {}  # one episode per task
    for workers in (1, 2):
        backends: dict[str, RolloutBackend] = {}
        try:
            for name, make in makers.items():
                if name == "ray" and figures["ray_error"]:
                    continue
                try:
                    backends[name], figures["startup"][name, workers] = start_backend(make, workers, config)
                except Exception as error:
                    if name != "ray":
                        raise
                    figures["ray_error"] = f"{type(error).__name__}: {(str(error).strip().splitlines() or [''])[0]}"
            walls: dict[str, list[float]] = {name: [] for name in backends}
            for _ in range(rounds):
                for name, backend in backends.items():
                    start = time.perf_counter()
                    trajectories[name] = [episode for road in backend.run(tasks) for rollout in road
                                          for episode in rollout]
                    walls[name].append(time.perf_counter() - start)
        finally:
            for backend in backends.values():
                backend.close()
        for name, values in walls.items():
            figures["wall"][name, workers] = median(values)
        if "ray" in walls:
            figures["overhead"][workers] = median(r / p - 1 for r, p in zip(walls["ray"], walls["process pool"],
                                                                            strict=True))
            figures["identical"] &= all(
                a.steps == b.steps and np.array_equal(a.observations, b.observations)
                for a, b in zip(trajectories["ray"], trajectories["process pool"], strict=True))
    return figures | {"trajectories": trajectories["process pool"]}


class ReplayBackend(RolloutBackend):
    """Answers task i with recorded trajectory i modulo their number, at once: `run_iteration` then times only the
    learner (discriminator steps, rewards, ARS update, statistics merge)."""

    def __init__(self, trajectories: list[Trajectory]) -> None:
        self.workers = 1
        self.trajectories = trajectories

    def run(self, tasks: Sequence[Any], on_result: Callable[[int, Any], None] | None = None) -> list[Any]:
        return [[[self.trajectories[index % len(self.trajectories)]]] for index in range(len(tasks))]

    def close(self) -> None:
        pass


def learner_seconds(config: Config, trajectories: list[Trajectory], directions: int, rounds: int) -> float:
    """Median wall time [s] of the learner's part of a RAIL iteration with `directions` directions (2 x directions
    recorded rollouts replayed), default discriminator; the recorded rollouts also stand in for the expert."""
    size = len(observation_names(config))
    shape = PolicyShape("mlp", size)
    expert = Demonstrations(np.concatenate([t.observations for t in trajectories]),
                            np.concatenate([t.actions for t in trajectories]), np.zeros(0), {})
    settings = RailSettings(directions=directions, top=directions // 2, common_traffic=False)
    backend = ReplayBackend(trajectories)
    times = []
    for _ in range(rounds):
        stats = RunningStats.of(expert.observations)
        discriminator = Discriminator(size, stats.mean.copy(), stats.std.copy(), DiscriminatorSettings())
        state = TrainingState.start(np.zeros(shape.parameter_count, dtype=np.float32), RunningStats.empty(size),
                                    settings)
        start = time.perf_counter()
        run_iteration(state, shape, config, settings, discriminator, expert, backend)
        times.append(time.perf_counter() - start)
    return median(times)


def backend_rows(figures: dict[str, Any], rollouts: int) -> str:
    rows = []
    for workers in (1, 2):
        for name in ("process pool", "ray"):
            if (name, workers) not in figures["wall"]:
                rows.append(f"| {name} | {workers} | not available | | |")
                continue
            wall = figures["wall"][name, workers]
            rows.append(f"| {name} | {workers} | {figures['startup'][name, workers]:.1f} | {wall:.1f} | "
                        f"{rollouts / wall:.2f} |")
    return "\n".join(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=4, help="episodes of our env per round (parts 1 and 2)")
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds of parts 1 and 2")
    parser.add_argument("--highway-seconds", type=int, default=12,
                        help="simulated seconds of highway-env per round (about 2 wall s each at 130 vehicles)")
    parser.add_argument("--highway-vehicles", type=int, default=None,
                        help="vehicles in highway-env (default: as many as ours on the road after a reset)")
    parser.add_argument("--rollouts", type=int, default=32, help="RAIL rollouts per backend run (part 3)")
    parser.add_argument("--backend-rounds", type=int, default=2, help="alternating pool / Ray rounds (part 3)")
    parser.add_argument("--directions", type=int, default=512, help="N of the projected iteration (part 4)")
    parser.add_argument("--learner-rounds", type=int, default=3, help="timed learner iterations (part 4)")
    parser.add_argument("--cores", type=int, nargs="+", default=[1, 2, 16, 64], help="cores of the projection")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks.md"))
    args = parser.parse_args()
    config = Config()
    one_hz = config.with_overrides({"env": {"decision_period_s": 1.0}})
    seeds = episode_seeds(Purpose.EVALUATE, 1000, args.episodes)
    transports = compare_transports(config, seeds, args.rounds)
    highway = compare_highway_env(one_hz, seeds, args.rounds, args.highway_seconds, args.highway_vehicles)
    tasks = rollout_tasks(config, args.rollouts)
    backends = compare_backends(config, tasks, args.backend_rounds)
    trajectories = backends["trajectories"]
    learner = learner_seconds(config, trajectories, args.directions, args.learner_rounds)

    decisions = statistics.mean(t.steps for t in trajectories)
    per_rollout = backends["wall"]["process pool", 1] / len(tasks)
    iteration_rollouts = 2 * args.directions
    projection = "\n".join(
        f"| {cores} | {iteration_rollouts * per_rollout / cores:.1f} | {learner:.1f} | "
        f"{iteration_rollouts * per_rollout / cores + learner:.1f} | "
        f"{100 * learner / (iteration_rollouts * per_rollout / cores + learner):.0f}% |" for cores in args.cores)
    if "error" in highway:
        highway_text = f"Not measured: {highway['error']}."
    else:
        highway_text = f"""\
| measure | ours | highway-env {highway['version']} |
|---|---|---|
| vehicles on the road after a reset (mean, ego included) | {highway['ours_vehicles']:.0f} | \
{highway['theirs_vehicles']} |
| simulated seconds per wall second, resets included | {highway['ours']:.1f} | {highway['theirs']:.2f} |

**Ours / highway-env: {highway['ratio']:.0f}x** (median of per-round ratios; target >= 50x)."""
    pool_speed_up = backends["wall"]["process pool", 1] / backends["wall"]["process pool", 2]
    if backends["overhead"]:
        overheads = ", ".join(f"{100 * value:+.1f}% on {workers} worker{'s' * (workers > 1)}"
                              for workers, value in backends["overhead"].items())
        ray_text = (f"Ray's overhead vs the process pool (median of per-round ratios of wall times, start-up "
                    f"excluded): **{overheads}** (target <= 10%). Both backends returned "
                    f"{'identical' if backends['identical'] else 'DIFFERENT'} trajectories.")
    else:
        ray_text = f"Ray: not available here ({backends['ray_error']})."
    transport_rates = transports["rates"]
    section = f"""
## Side by side: TraCI, highway-env, Ray, and a projection

Command: `make bench` (runs `{' '.join(['python', *sys.argv])}`).
Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, SUMO {sumo_version()}.
Default scenario ({config.scenario.flow_veh_per_h:.0f} veh/h) throughout; medians over alternating rounds.

### libsumo vs TraCI

The same {args.episodes} episodes of the 'keep' driver (decision period {config.env.decision_period_s} s, about
{transports['decisions']} decisions a round, resets included, SUMO started before the timing) x {args.rounds}
rounds on each transport; the traffic was {"the same" if transports['same'] else "NOT the same"} (equal decision
counts; tests/sim/test_env.py checks bit-identical observations and rewards).

| transport | decisions/s |
|---|---|
| libsumo (in-process) | {transport_rates['libsumo']:.0f} |
| traci (socket to a `sumo` process) | {transport_rates['traci']:.0f} |

**libsumo / traci: {transports['ratio']:.2f}x** (median of per-round ratios; target >= 1.5x).

### vs highway-env's highway-v0

Ours: 1 s decisions (`env.decision_period_s = 1.0`, 10 SUMO steps of {config.scenario.step_length_s} s), 'keep'
driver, {args.episodes} episodes a round. highway-env: `highway-v0` with 5 lanes, as many vehicles as ours,
`policy_frequency` 1 and `simulation_frequency` {highway.get('simulation_frequency', 15)}, no rendering, the IDLE
action, {args.highway_seconds} simulated seconds a round (a crash resets). {args.rounds} alternating rounds.

{highway_text}

### Rollouts: process pool vs Ray (local)

{args.rollouts} RAIL rollout tasks (`RolloutTask` of iteration 0: {args.rollouts // 2} directions, both signs, for a
zero-parameter two-layer policy perturbed by nu = {NoiseAdaptation().initial}; {decisions:.0f} decisions a rollout
on average), the same tasks on every backend, {args.backend_rounds} alternating rounds (both backends stay up through
each other's rounds). Start-up (backend made,
every worker's SUMO started, Ray started where it applies) is timed on its own and left out of the rollout times.

| backend | workers | start-up [s] | {args.rollouts} rollouts [s] | rollouts/s |
|---|---|---|---|---|
{backend_rows(backends, args.rollouts)}

{ray_text} Process pool speed-up with 2 workers: {pool_speed_up:.2f}x.

### Projection: one N = {args.directions} iteration ({iteration_rollouts} rollouts)

**A projection, not a measurement.** Inputs: {per_rollout:.2f} s per rollout (process pool, 1 worker, above) and
{learner:.2f} s of learner per iteration (measured: `run_iteration` with N = {args.directions} on
{iteration_rollouts} replayed rollouts of the table above, ~{iteration_rollouts * decisions:.0f} pairs, so only
the discriminator's steps, the rewards, the ARS update and the statistics merge are timed). Assumes rollouts
scale perfectly with cores (no start-up, no stragglers, no transfer cost) and the learner runs serially after
them, on one core, at the speed measured here. The rollout time scales with the episodes' length
({decisions:.0f} decisions here).

| cores | rollouts [s] | learner [s] | iteration [s] | learner share |
|---|---|---|---|---|
{projection}
"""
    write_section(args.out, "comparison", section)


if __name__ == "__main__":
    main()
