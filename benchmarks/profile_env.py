"""Profile: where a decision's time goes in the environment, by part, in microseconds per decision.

Runs 'keep' episodes (the ego keeps its lane and set-point, as in bench_env's ratio) with timers wrapped around
the parts of a decision: SUMO's steps (the step of `sumo_api.decision_calls`), the per-step ego checks (the rest of
`Simulation.advance_egos`), the context query and its parsing (`Simulation.observe`), LIDAR + observation
(`Ego.observation`), the rest of `HighwayEnv.step` (bookkeeping) and resets (amortised). The timers add
about 0.1 us per wrapped call. Prints a Markdown table; the environment's own cost is everything but SUMO's
steps and resets. Usage: `python benchmarks/profile_env.py [--flow 3000] [--episodes 6] [--rounds 3]`.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any

from sumo_rail.config import Config
from sumo_rail.sim import simulation
from sumo_rail.sim.ego import Ego
from sumo_rail.sim.env import HighwayEnv

PARTS = ("SUMO steps", "per-step checks", "context query + parsing", "LIDAR + observation", "step bookkeeping",
         "reset (amortised)")


class Timers:
    """Inclusive wall time [s] per label."""

    def __init__(self) -> None:
        self.total: dict[str, float] = defaultdict(float)

    def wrap(self, label: str, function: Callable[..., Any]) -> Callable[..., Any]:
        total, clock = self.total, time.perf_counter

        def timed(*args: Any, **kwargs: Any) -> Any:
            start = clock()
            try:
                return function(*args, **kwargs)
            finally:
                total[label] += clock() - start
        return timed


def profile_round(config: Config, seeds: list[int]) -> dict[str, float]:
    """One round of episodes; microseconds per decision for each part."""
    timers = Timers()
    calls = simulation.decision_calls  # SUMO's step is one of the calls found once per connection

    def timed_calls(api: Any) -> Any:
        found = calls(api)
        return found._replace(step=timers.wrap("steps", found.step))

    patches = [(simulation, "decision_calls", None), (simulation.Simulation, "advance_egos", "advance"),
               (simulation.Simulation, "observe", "observe"), (Ego, "observation", "lidar"),
               (HighwayEnv, "step", "step"), (HighwayEnv, "reset", "reset")]
    originals = [(owner, name, getattr(owner, name)) for owner, name, _ in patches]
    for owner, name, label in patches:
        setattr(owner, name, timed_calls if label is None else timers.wrap(label, getattr(owner, name)))
    env = HighwayEnv(config)
    env.reset(seed=seeds[0])  # warm states and first-use costs outside the timing
    timers.total.clear()
    decisions = 0
    try:
        for seed in seeds:
            before = timers.total["steps"]
            env.reset(seed=seed)
            timers.total["reset_steps"] += timers.total["steps"] - before
            done = False
            while not done:
                _, _, terminated, truncated, _ = env.step(0)
                decisions += 1
                done = terminated or truncated
    finally:
        env.close()
        for owner, name, original in originals:
            setattr(owner, name, original)
    t = timers.total
    step_sumo = t["steps"] - t["reset_steps"]
    observe_in_step = t["observe"] * decisions / (decisions + len(seeds))  # reset observes once too
    lidar_in_step = t["lidar"] * decisions / (decisions + len(seeds))
    parts = {
        "SUMO steps": step_sumo,
        "per-step checks": t["advance"] - step_sumo,
        "context query + parsing": observe_in_step,
        "LIDAR + observation": lidar_in_step,
        "step bookkeeping": t["step"] - t["advance"] - observe_in_step - lidar_in_step,
        "reset (amortised)": t["reset"],
    }
    return {name: 1e6 * value / decisions for name, value in parts.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--flow", type=float, default=3000.0, help="background flow [veh/h]")
    parser.add_argument("--episodes", type=int, default=6)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    config = Config().with_overrides({"scenario": {"flow_veh_per_h": args.flow}})
    seeds = list(range(1000, 1000 + args.episodes))
    rounds = [profile_round(config, seeds) for _ in range(args.rounds)]
    medians = {name: statistics.median(r[name] for r in rounds) for name in PARTS}
    own = sum(medians[name] for name in PARTS[1:5])
    print(f"flow {args.flow:.0f} veh/h, {args.episodes} episodes x {args.rounds} rounds, medians [us/decision]")
    print("| part | us/decision | rounds |\n|---|---|---|")
    for name in PARTS:
        print(f"| {name} | {medians[name]:.0f} | {', '.join(f'{r[name]:.0f}' for r in rounds)} |")
    print(f"| **environment's own cost** (checks + context + LIDAR/observation + bookkeeping) | **{own:.0f}** | |")


if __name__ == "__main__":
    main()
