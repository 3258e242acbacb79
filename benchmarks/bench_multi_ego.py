"""Benchmark: decisions per core-second of the multi-ego env (K egos in one SUMO, `sumo_rail.parallel_env`) for
several K, against raw libsumo stepping and the single-ego `HighwayEnv`, in one run.

Every side drives whole episodes of the default scenario on the same reset seeds, resets included; the egos keep
their lane and set-point (as in bench_env's ratio), and a second pass drives them at random (seeded). Rounds
alternate the sides so machine noise hits all of them; each figure is the median over rounds. Rates are decisions
(one ego's decision period) per second of this process's CPU time, i.e. per core; the wall-clock rate is shown
beside. Raw libsumo steps the single ego's episodes for the same simulated time (bench_env's `raw_round`), with
its resets left out: the most one SUMO gives one ego. Writes its section of docs/benchmarks.md (between markers).
"""

from __future__ import annotations

import dataclasses
import os
import platform
import statistics
import sys

import numpy as np
from bench_env import clocks, env_round, raw_round
from doc_section import bench_parser, write_section

import sumo_rail
from sumo_rail.config import Config
from sumo_rail.datasets import sumo_version
from sumo_rail.learning.sb3.shared_road import RespawningRoad
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.parallel_env import ParallelHighwayEnv
from sumo_rail.sim.simulation import Simulation
from sumo_rail.sim.starts import MIN_SLOT_M

EGOS = (1, 2, 4, 8, 16)


@dataclasses.dataclass
class Pass:
    """One round of one side: (wall, CPU) time [s], decisions, and per ego episode its decisions and mean speed
    [m/s], and the egos' collisions."""

    elapsed: np.ndarray
    decisions: int
    periods: int = 0
    """Decision periods of the shared simulation."""
    episode_decisions: list[int] = dataclasses.field(default_factory=list)
    speeds_mps: list[float] = dataclasses.field(default_factory=list)
    collisions: int = 0


def multi_round(env: ParallelHighwayEnv, seeds: list[int], random_actions: bool) -> Pass:
    """Whole episodes of every ego, resets included, keeping or random actions (seeded per episode)."""
    result = Pass(np.zeros(2), 0)
    start = clocks()
    for seed in seeds:
        env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        while env.agents:
            actions = {agent: int(rng.integers(5)) if random_actions else 0 for agent in env.agents}
            result.decisions += len(env.step(actions)[1])
            result.periods += 1
        for metrics in map(env.metrics, env.possible_agents):
            result.episode_decisions.append(metrics.decisions)
            result.speeds_mps.append(metrics.average_speed_mps)
            result.collisions += metrics.collisions
    result.elapsed = clocks() - start
    return result


def respawn_round(road: RespawningRoad, periods: int, seed: int, random_actions: bool) -> Pass:
    """`periods` decision periods of a road whose egos respawn, from its (untimed) reset; episodes are those that
    ended."""
    result = Pass(np.zeros(2), 0)
    rng = np.random.default_rng(seed)
    egos = road.env.max_num_agents
    episode_decisions = np.zeros(egos, dtype=np.int64)
    start = clocks()
    while result.periods < periods:
        actions = rng.integers(5, size=egos).tolist() if random_actions else [0] * egos
        _, _, dones, infos = road.step(actions)
        result.decisions += egos
        result.periods += 1
        episode_decisions += 1
        for ego in np.flatnonzero(dones):
            info = infos[ego]
            result.episode_decisions.append(int(episode_decisions[ego]))
            result.speeds_mps.append(info["distance_m"] / max(info["time_s"], 1e-9))
            result.collisions += info["collisions"]
        episode_decisions[dones] = 0
    result.elapsed = clocks() - start
    return result


def measure(config: Config, seeds: list[int], rounds: int, random_actions: bool) -> dict[str, list[Pass]]:
    """Alternating rounds of raw libsumo, the single-ego env, the multi-ego env for each K and the respawning
    road for each K."""
    passes: dict[str, list[Pass]] = {"raw": [], "single": [], **{f"K={k}": [] for k in EGOS},
                                     **{f"respawn K={k}": [] for k in EGOS}}
    for _ in range(rounds):
        single = HighwayEnv(config)
        single.reset(seed=0)  # SUMO started and the kernels loaded outside the timing
        elapsed, decisions = env_round(single, seeds, random_actions)
        passes["single"].append(Pass(elapsed, sum(decisions), sum(decisions), decisions))
        single.close()
        sim = Simulation(config.scenario, context_radius_m=config.lidar.range_m + 20.0)
        stepping, _, _ = raw_round(sim, config, seeds, decisions)
        passes["raw"].append(Pass(stepping, sum(decisions)))
        sim.close()
        for egos in EGOS:
            env = sumo_rail.parallel_env(egos=egos, config=config)
            env.reset(seed=0)
            passes[f"K={egos}"].append(multi_round(env, seeds, random_actions))
            env.close()
        for egos in EGOS:
            road = RespawningRoad(config, egos, seed=seeds[0])
            road.reset()
            passes[f"respawn K={egos}"].append(respawn_round(road, sum(decisions), seeds[0], random_actions))
            road.close()
    return passes


def rate(passes: list[Pass], clock: int) -> float:
    """Median decisions per second over rounds, on the wall (0) or CPU (1) clock."""
    return statistics.median(p.decisions / p.elapsed[clock] for p in passes)


def table(passes: dict[str, list[Pass]]) -> str:
    single, raw = rate(passes["single"], 1), rate(passes["raw"], 1)
    rows = [f"| raw libsumo stepping, one ego (no resets) | {raw:.0f} | {raw / single:.2f} | 1.00 | "
            f"{rate(passes['raw'], 0):.0f} | | | | |",
            f"| single-ego `HighwayEnv` | {single:.0f} | 1.00 | {single / raw:.2f} | {rate(passes['single'], 0):.0f} "
            f"| {statistics.mean(passes['single'][-1].episode_decisions):.0f} | | | 1 |"]
    for name, key in [(f"`parallel_env`, K = {k}", f"K={k}") for k in EGOS] + \
            [(f"respawning egos (gail.egos/ppo.egos), K = {k}", f"respawn K={k}") for k in EGOS]:
        multi = passes[key]
        last = multi[-1]
        k_rate = rate(multi, 1)
        rows.append(f"| {name} | {k_rate:.0f} | **{k_rate / single:.2f}** | {k_rate / raw:.2f} | "
                    f"{rate(multi, 0):.0f} | {statistics.mean(last.episode_decisions):.0f} | "
                    f"{3.6 * statistics.mean(last.speeds_mps):.1f} | {last.collisions} | "
                    f"{last.decisions / last.periods:.1f} |")
    header = ("| side | decisions per core-second | x single-ego env | x raw libsumo | decisions per wall-second | "
              "decisions per ego episode | mean ego speed [km/h] | ego collisions | egos driving per period |\n"
              "|---|---|---|---|---|---|---|---|---|")
    return header + "\n" + "\n".join(rows)


def main() -> None:
    args = bench_parser(__doc__, 4, "episodes per side and round", 3, "alternating rounds").parse_args()
    config = Config()
    seeds = list(range(1000, 1000 + args.episodes))
    keep = measure(config, seeds, args.rounds, random_actions=False)
    random = measure(config, seeds, args.rounds, random_actions=True)
    scenario, env = config.scenario, config.env
    window_m = env.ego_start_max_m - env.ego_start_min_m
    widened = [k for k in EGOS if window_m / k < MIN_SLOT_M]
    widening = (f"from K = {widened[0]} the slots are {MIN_SLOT_M:.0f} m wide and reach past the window"
                if widened else "the window is wide enough for every K")
    at_8 = {name: rate(passes["K=8"], 1) / rate(passes["single"], 1)
            for name, passes in (("keep", keep), ("random", random))}
    respawning_8 = {name: rate(passes["respawn K=8"], 1) / rate(passes["single"], 1)
                    for name, passes in (("keep", keep), ("random", random))}
    section = f"""
## Several egos in one SUMO (issue 28)

Command: `make bench` (runs `{' '.join(['python', *sys.argv])}`).
Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, SUMO {sumo_version()};
one process, one core. Default scenario: {scenario.lanes} lanes, {scenario.length_m:.0f} m, \
{scenario.flow_veh_per_h:.0f} veh/h, decision period {env.decision_period_s} s.

- Each side drives {args.episodes} whole episodes (seeds {seeds[0]}-{seeds[-1]}), resets included (raw libsumo:
  stepping only), in {args.rounds} alternating rounds; medians over rounds. A decision is one ego's decision
  period: K egos make up to K decisions per period of their shared simulation.
- K = 1 drives the single-ego env's very episodes (bit for bit), so its ratio to the single-ego env shows the
  noise of these measurements on this machine.
- K egos start in K slots of the single ego's start window ({env.ego_start_min_m:.0f}-{env.ego_start_max_m:.0f} m;
  {widening};
  `sumo_rail/sim/starts.py`). An episode lasts until its last ego has finished, so its slowest ego sets its
  length and the egos that finished early make no decisions meanwhile: the column "egos driving per period" is
  the mean number of egos deciding in each period. A 'keep' ego keeps the set-point it started with,
  its speed when it entered the road, which is the lowest set-point (36 km/h) when it entered behind a slow
  vehicle; one such ego in K drags an episode out.
- Respawning egos (`sumo_rail/learning/sb3/shared_road.py`, what `gail.egos` and `ppo.egos` = K run in each
  environment process): an ego that finishes is replaced at once in the start window, so all K egos decide in
  every period. Each drives as many periods as the single-ego env's episodes have decisions (the same simulated
  time), from one (untimed) reset.
- The last four columns describe the last round's episodes (every ego of each; for respawning egos, the episodes
  that ended).

Egos keep their lane and set-point: at K = 8, **{at_8["keep"]:.2f}x** the single-ego env's decisions per core
(target: at least 3x); respawning egos at K = 8: **{respawning_8["keep"]:.2f}x**.

{table(keep)}

Random actions (more lane changes, which make SUMO itself slower): at K = 8, **{at_8["random"]:.2f}x**; respawning
egos at K = 8: **{respawning_8["random"]:.2f}x**.

{table(random)}
"""
    write_section(args.out, "multi_ego", section)


if __name__ == "__main__":
    main()
