"""A reference for the search (issue 25): the project's ARS against sb3-contrib's on standard Gymnasium tasks.

Both implementations train a linear policy from zero weights with the same number of directions N, kept
directions b, step size alpha and perturbation scale nu (`TASKS`), and are scored the same way: the mean return of
deterministic test episodes on fixed seeds (`TEST_SEED`, the same episodes for both), after the first iteration
that crosses each multiple of the task's evaluation interval; x is environment steps of training rollouts (test
episodes are not counted, as in Mania et al.).

- "sumo-rail": this driver around the library's `ars_update`, `directions` (seeded by the run's seed), `Policy`
  (linear, with bias; Discrete: argmax of the logits, Box: the logits clipped to the action space) and
  `RunningStats`: Mania et al.'s V2 normalisation, statistics frozen during an iteration and merged from the
  states of its rollouts afterwards. Each rollout's environment seed is drawn from a generator of the run's seed.
- "sb3-contrib": `sb3_contrib.ARS("LinearPolicy")` with `zero_policy=True` (zero initial weights, as Mania et al.
  and the driver above), `policy_kwargs={"with_bias": True}` (the project's linear policy has a bias; sb3's
  default has none), one episode per candidate and, for V2, `VecNormalize(norm_obs=True, norm_reward=False)`.

Writes OUT/curves.csv (implementation, task, seed, env_steps, return), OUT/ars_reference.png (per task, both
implementations' mean over seeds with the seeds' range shaded) and OUT/table.md (steps to the task's threshold and
final return per seed). Resumable: runs (implementation, task, seed) already in OUT/curves.csv are skipped; the
figure and table are drawn from every run there. Progress lines go to stderr.

Usage: python experiments/ars_reference.py [--task T ...] [--seeds S ...] [--steps STEPS] [--step-size ALPHA]
       [--implementation I ...] [--out OUT]
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import EngFormatter

from sumo_rail.drivers.policies import Policy, PolicyShape
from sumo_rail.learning.rail.ars import ars_update
from sumo_rail.learning.rail.noise import directions
from sumo_rail.learning.rail.normalize import RunningStats
from sumo_rail.report.markdown import save_png, write_atomically

PROJECT, SB3 = "sumo-rail", "sb3-contrib"
IMPLEMENTATIONS = (PROJECT, SB3)
TEST_SEED = 1_000_000
"""Test episode k of every evaluation starts from environment seed TEST_SEED + k."""
COLUMNS = ["implementation", "task", "seed", "env_steps", "return"]
FINAL = 3
"""A run's final return is the mean of its last FINAL evaluations (one evaluation is noisy)."""


@dataclass(frozen=True)
class Search:
    """One task's ARS settings, the same for both implementations, and how it is scored."""

    directions: int
    """N, directions per iteration (2N rollouts of one episode each)."""
    top: int
    """b, the directions with the largest max(r+, r-) kept for the step."""
    step_size: float
    """alpha [parameter units per unit of normalised return difference]."""
    noise: float
    """nu, the perturbation scale [parameter units]."""
    normalize: bool
    """Mania et al.'s V2 state normalisation (False: V1, raw observations)."""
    steps: int
    """Training budget [environment steps]."""
    evaluate_every: int
    """Evaluation interval [environment steps]."""
    threshold: float
    """The return counted as solving the task [the task's reward units]."""
    test_episodes: int = 5
    """Deterministic test episodes per evaluation."""


TASKS = {
    # sb3-contrib's default N, alpha, nu, half the directions kept (the ARS V2-t top-b step), V2 normalisation;
    # thresholds: Gymnasium's reward_threshold of the task.
    "CartPole-v1": Search(8, 4, 0.02, 0.05, True, steps=50_000, evaluate_every=2_000, threshold=475.0,
                          test_episodes=10),
    "Acrobot-v1": Search(8, 4, 0.02, 0.05, True, steps=150_000, evaluate_every=5_000, threshold=-100.0,
                         test_episodes=10),
    # Mania et al.'s Swimmer: N = b = 1, alpha = 0.02, nu = 0.01, no normalisation (their best version there, V1);
    # threshold 325, theirs (Gymnasium's is 360).
    "Swimmer-v5": Search(1, 1, 0.02, 0.01, False, steps=500_000, evaluate_every=20_000, threshold=325.0,
                         test_episodes=3),
}

Chooser = Callable[[np.ndarray], Any]
"""An action for an observation."""
Reporter = Callable[[int, float], None]
"""Called with (environment steps, test return) at each evaluation."""


def episode(env: gym.Env, choose: Chooser, seed: int, states: list[np.ndarray] | None = None) -> tuple[float, int]:
    """Return [reward units] and length [steps] of one episode from `env.reset(seed=seed)`; appends every
    observation an action is chosen on to `states` if given."""
    observation, _ = env.reset(seed=seed)
    total, length, done = 0.0, 0, False
    while not done:
        if states is not None:
            states.append(observation)
        observation, reward, terminated, truncated, _ = env.step(choose(observation))
        total, length, done = total + float(reward), length + 1, terminated or truncated
    return total, length


def evaluate(task: str, choose: Chooser, episodes: int) -> float:
    """Mean return [reward units] of `episodes` test episodes (seeds TEST_SEED, TEST_SEED + 1, ...)."""
    env = gym.make(task)
    try:
        return float(np.mean([episode(env, choose, TEST_SEED + k)[0] for k in range(episodes)]))
    finally:
        env.close()


def chooser(policy: Policy, space: gym.Space) -> Chooser:
    """The policy's action: argmax of the logits (Discrete) or the logits clipped to the space (Box)."""
    if isinstance(space, gym.spaces.Discrete):
        return policy.act
    if isinstance(space, gym.spaces.Box):
        return lambda observation: np.clip(policy.logits(observation), space.low, space.high)
    raise ValueError(f"only Discrete and Box action spaces are supported, got {space}")


def next_mark(steps: int, every: int) -> int:
    """The first multiple of `every` above `steps` [environment steps]: when the next evaluation falls due."""
    return (steps // every + 1) * every


def train_project(task: str, search: Search, seed: int, steps: int, report: Reporter) -> None:
    """Train with the project's ARS for at least `steps` environment steps, reporting each evaluation."""
    env = gym.make(task)
    space, size = env.action_space, env.observation_space.shape[0]
    shape = PolicyShape("linear", size, actions=space.n if isinstance(space, gym.spaces.Discrete) else space.shape[0])
    theta, stats = np.zeros(shape.parameter_count, np.float32), RunningStats.empty(size)
    rollout_seeds = np.random.default_rng(seed)

    def policy(parameters: np.ndarray) -> Policy:
        return Policy(shape, parameters, stats.mean, stats.std) if search.normalize else Policy(shape, parameters)

    report(0, evaluate(task, chooser(policy(theta), space), search.test_episodes))
    used, mark, iteration = 0, search.evaluate_every, 0
    while used < steps:
        deltas = directions(seed, iteration, search.directions, theta.size)
        returns, states = np.empty((2, search.directions)), []
        for k in range(search.directions):
            for side, sign in enumerate((1.0, -1.0)):
                candidate = chooser(policy(theta + sign * search.noise * deltas[k]), space)
                returns[side, k], length = episode(env, candidate, int(rollout_seeds.integers(2**31)), states)
                used += length
        theta = ars_update(theta, deltas, returns[0], returns[1], search.top, search.step_size).parameters
        stats = stats.merge(RunningStats.of(np.asarray(states)))
        iteration += 1
        if used >= mark:
            report(used, evaluate(task, chooser(policy(theta), space), search.test_episodes))
            mark = next_mark(used, search.evaluate_every)
    env.close()


def train_sb3(task: str, search: Search, seed: int, steps: int, report: Reporter) -> None:
    """Train with sb3-contrib's ARS for at least `steps` environment steps, reporting each evaluation at the
    same marks as `train_project` (after the first iteration that crosses each multiple of the interval)."""
    import torch
    from sb3_contrib import ARS
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    torch.set_num_threads(1)
    env = DummyVecEnv([lambda: gym.make(task)])
    if search.normalize:
        env = VecNormalize(env, norm_obs=True, norm_reward=False)
    model = ARS("LinearPolicy", env, n_delta=search.directions, n_top=search.top, learning_rate=search.step_size,
                delta_std=search.noise, zero_policy=True, alive_bonus_offset=0.0, n_eval_episodes=1,
                policy_kwargs={"with_bias": True}, seed=seed)

    def choose(observation: np.ndarray) -> Any:
        seen = env.normalize_obs(observation) if search.normalize else observation
        return model.predict(seen, deterministic=True)[0]

    report(0, evaluate(task, choose, search.test_episodes))
    mark = search.evaluate_every
    while model.num_timesteps < steps:
        model.learn(mark - model.num_timesteps, reset_num_timesteps=False)
        report(model.num_timesteps, evaluate(task, choose, search.test_episodes))
        mark = next_mark(model.num_timesteps, search.evaluate_every)
    env.close()


TRAINERS = {PROJECT: train_project, SB3: train_sb3}


def run(implementation: str, task: str, search: Search, seed: int, steps: int) -> pd.DataFrame:
    """One training run's curve (COLUMNS), with a progress line per evaluation on stderr."""
    rows, start = [], time.monotonic()

    def report(env_steps: int, value: float) -> None:
        rows.append((implementation, task, seed, env_steps, value))
        print(f"{implementation} {task} seed {seed}: {env_steps} steps, test return {value:.1f} "
              f"({time.monotonic() - start:.0f} s)", file=sys.stderr, flush=True)

    TRAINERS[implementation](task, search, seed, steps, report)
    return pd.DataFrame(rows, columns=COLUMNS)


def missing_runs(curves: pd.DataFrame, implementations: list[str], tasks: list[str], seeds: list[int]
                 ) -> Iterator[tuple[str, str, int]]:
    """The (implementation, task, seed) runs not yet in `curves`, tasks outermost."""
    done = set(curves[["implementation", "task", "seed"]].itertuples(index=False, name=None))
    for task in tasks:
        for seed in seeds:
            for implementation in implementations:
                if (implementation, task, seed) not in done:
                    yield implementation, task, seed


def steps_to_threshold(curve: pd.DataFrame, threshold: float) -> int | None:
    """Environment steps of the first evaluation whose test return reaches `threshold`, None if none does."""
    reached = curve[curve["return"] >= threshold]
    return int(reached["env_steps"].iloc[0]) if len(reached) else None


def seed_curves(curves: pd.DataFrame, implementation: str, task: str) -> dict[int, pd.DataFrame]:
    """Each seed's curve of one implementation on one task, by environment steps."""
    chosen = curves[(curves["implementation"] == implementation) & (curves["task"] == task)]
    return {int(seed): curve.sort_values("env_steps") for seed, curve in chosen.groupby("seed")}


def plot(curves: pd.DataFrame) -> Figure:
    """One panel per task: each implementation's test return, mean over seeds (interpolated on a common grid of
    environment steps up to the shortest run) with the seeds' range shaded, and the task's threshold dotted."""
    tasks = list(dict.fromkeys(curves["task"]))
    figure = Figure(figsize=(4.2 * len(tasks), 3.4), layout="constrained")
    FigureCanvasAgg(figure)
    for axes, task in zip(figure.subplots(1, len(tasks), squeeze=False)[0], tasks, strict=True):
        for implementation, colour in zip(IMPLEMENTATIONS, ("tab:blue", "tab:orange"), strict=True):
            runs = seed_curves(curves, implementation, task)
            if not runs:
                continue
            grid = np.linspace(0, min(run["env_steps"].iloc[-1] for run in runs.values()), 200)
            values = np.array([np.interp(grid, run["env_steps"], run["return"]) for run in runs.values()])
            axes.plot(grid, values.mean(axis=0), color=colour, label=f"{implementation} ({len(runs)} seeds)")
            axes.fill_between(grid, values.min(axis=0), values.max(axis=0), color=colour, alpha=0.2, linewidth=0)
        axes.axhline(TASKS[task].threshold, color="grey", linestyle=":", linewidth=1)
        axes.set(title=task, xlabel="environment steps", ylabel="test return")
        axes.xaxis.set_major_formatter(EngFormatter())
        axes.legend(fontsize="small", loc="lower right")
    return figure


def final_return(curve: pd.DataFrame) -> float:
    """Mean test return of the curve's last FINAL evaluations [reward units]."""
    return float(curve["return"].iloc[-FINAL:].mean())


def median_steps(reached: dict[int, int | None]) -> str:
    """'median 12,000 (4/5 reached)': the median over the seeds that reached the threshold."""
    hits = [steps for steps in reached.values() if steps is not None]
    count = f"{len(hits)}/{len(reached)} reached"
    return f"median {np.median(hits):,.0f} ({count})" if hits else count


def row(label: str, seed: str, steps: list[str], finals: list[str]) -> str:
    """One Markdown table row."""
    return f"| {label} | {seed} | " + " | ".join(steps + finals) + " |"


def table(curves: pd.DataFrame) -> str:
    """Markdown: per task and seed, each implementation's steps to the threshold and final return, then per task
    the median steps to the threshold (over the seeds that reached it) and the mean final return."""
    lines = [row("task (threshold)", "seed", [f"{name}: steps to threshold" for name in IMPLEMENTATIONS],
                 [f"{name}: final return" for name in IMPLEMENTATIONS]),
             "|---|---|" + "---|" * (2 * len(IMPLEMENTATIONS))]
    for task in dict.fromkeys(curves["task"]):
        label = f"{task} ({TASKS[task].threshold:g})"
        runs = [seed_curves(curves, name, task) for name in IMPLEMENTATIONS]
        reached = [{seed: steps_to_threshold(curve, TASKS[task].threshold) for seed, curve in found.items()}
                   for found in runs]
        for seed in sorted(set().union(*runs)):
            steps = ["-" if seed not in found else "not reached" if found[seed] is None else f"{found[seed]:,}"
                     for found in reached]
            finals = [f"{final_return(found[seed]):.1f}" if seed in found else "-" for found in runs]
            lines.append(row(label, str(seed), steps, finals))
        steps = [median_steps(found) if found else "-" for found in reached]
        finals = [f"mean {np.mean([final_return(curve) for curve in found.values()]):.1f}" if found else "-"
                  for found in runs]
        lines.append(row(label, "all", steps, finals))
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--task", nargs="+", choices=sorted(TASKS), default=list(TASKS), help="Gymnasium env ids")
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2], help="training seeds")
    parser.add_argument("--steps", type=int, help="training budget [environment steps] (default: the task's)")
    parser.add_argument("--step-size", type=float, help="alpha for every task (default: the task's)")
    parser.add_argument("--implementation", nargs="+", choices=IMPLEMENTATIONS, default=list(IMPLEMENTATIONS))
    parser.add_argument("--out", type=Path, default=Path("ars_reference"), help="output folder")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "curves.csv"
    curves = pd.read_csv(path) if path.is_file() else pd.DataFrame(columns=COLUMNS)
    for implementation, task, seed in list(missing_runs(curves, args.implementation, args.task, args.seeds)):
        search = TASKS[task] if args.step_size is None else replace(TASKS[task], step_size=args.step_size)
        found = run(implementation, task, search, seed, args.steps or search.steps)
        curves = found if curves.empty else pd.concat([curves, found], ignore_index=True)
        write_atomically(path, curves.to_csv(index=False, float_format="%.6g").encode())
    save_png(plot(curves), args.out / "ars_reference.png")
    write_atomically(args.out / "table.md", table(curves).encode())


if __name__ == "__main__":
    main()
