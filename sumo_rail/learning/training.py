"""A training run in a folder: BC initialisation, RAIL iterations, atomic checkpoints, resume, the training log.

runs/NAME/ holds `run.json` (settings, config, provenance), `checkpoint.pt` (everything to continue exactly;
written with torch.save and read with `weights_only=True`, so loading never runs code), `policy_bc.npz`,
`policy_latest.npz`, `policy_best.npz` (by mean discriminator return), `discriminator.pt` and `log.parquet`
(one row per iteration; every `Validation.every` iterations it also holds the policy's mean episode metrics on
validation seeds, `eval_*` columns, null otherwise). Every file is replaced atomically after each iteration, so an
interrupted run keeps its last complete iteration and `--resume` continues from it bit for bit.
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import torch

from sumo_rail.config import Config
from sumo_rail.datasets import write_parquet
from sumo_rail.drivers.policies import Policy, PolicyShape, save_policy
from sumo_rail.evaluation.evaluate import evaluate
from sumo_rail.evaluation.statistics import ratio
from sumo_rail.evaluation.summary import measure_samples
from sumo_rail.learning.bc import BcReport, BcSettings, behaviour_cloning
from sumo_rail.learning.discriminator import Discriminator, DiscriminatorSettings
from sumo_rail.learning.normalize import RunningStats
from sumo_rail.learning.rail import RailSettings, TrainingState, run_iteration
from sumo_rail.runners.backends import RolloutBackend
from sumo_rail.runners.rollout import PolicyDriver
from sumo_rail.runners.tables import provenance, read_demonstrations
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.observation import observation_space

CHECKPOINT_FORMAT = "sumo-rail checkpoint 1"


@dataclass(frozen=True)
class RunSettings:
    """What defines a run; `--resume` requires the same (except the number of iterations)."""

    demos: str
    kind: str
    hidden: int
    bc_epochs: int
    rail: RailSettings
    discriminator: DiscriminatorSettings
    bc_class_balance: float = 0.0
    """`BcSettings.class_balance`."""

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


VALIDATION_BASE_SEED = 1_000_000
"""Validation episodes use evaluation-class seeds from this base, far from `evaluate`'s default test seeds."""
VALIDATION_METRICS = ("agreement", "lane_change_recall", "lane_change_precision", "average_speed_kmh", "overtakes",
                      "lane_changes", "longitudinal_reward", "lateral_reward", "collisions")
"""Measures the log holds as eval_<measure>: the agreement rates with the expert (pooled over the validation
decisions) and the episode metrics' means."""


@dataclass(frozen=True)
class Validation:
    """Evaluate the policy every `every` iterations (and after the last) on `episodes` validation seeds."""

    every: int = 0
    """0: never."""
    episodes: int = 8

    def __post_init__(self) -> None:
        if self.every < 0 or self.episodes < 1:
            raise ValueError(f"validation needs every >= 0 and episodes >= 1, got {self}")

    def due(self, iteration: int, last: int) -> bool:
        """Whether the policy after `iteration` (0-based) is evaluated in a run of `last` + 1 iterations."""
        return self.every > 0 and ((iteration + 1) % self.every == 0 or iteration == last)


class RunError(ValueError):
    """A run folder cannot be used as asked (message is one sentence)."""


def train(folder: Path, settings: RunSettings, config: Config, iterations: int, backend: RolloutBackend,
          resume: bool, validation: Validation = Validation(),
          on_bc: Callable[[BcReport], None] | None = None,
          on_iteration: Callable[[dict[str, Any]], None] | None = None,
          on_rollout: Callable[[int, Any], None] | None = None) -> TrainingState:
    """Train until `iterations` iterations are done; returns the final state. Safe to interrupt at any time.

    `on_bc` receives the behaviour-cloning report (new runs with bc_epochs > 0); `on_iteration` each iteration's
    log row (IterationLog fields, wall_time_s and eval_* metrics); `on_rollout` each rollout as it arrives."""
    folder = Path(folder)
    observation_size = observation_space(config).shape[0]
    demos = read_demonstrations(Path(settings.demos), observation_size)
    shape = PolicyShape(settings.kind, observation_size, settings.hidden)
    run_record = {"settings": settings.to_dict(), "expert_style": demos.metadata.get("style"),
                  **provenance("training_run", config, settings.rail.seed)}
    expert_stats = RunningStats.of(demos.observations)
    discriminator = Discriminator(observation_size, expert_stats.mean.copy(), expert_stats.std.copy(),
                                  settings.discriminator)
    if resume:
        state, logs = _resume(folder, run_record, shape, discriminator)
    else:
        _start_folder(folder, run_record)
        state, logs = _initial_state(folder, settings, shape, demos, run_record, on_bc), []
    while state.iteration < iterations:
        started = time.perf_counter()
        log = run_iteration(state, shape, config, settings.rail, discriminator, demos, backend, on_rollout)
        row = {**dataclasses.asdict(log), "wall_time_s": time.perf_counter() - started}
        policy = Policy(shape, state.parameters, state.stats.mean, state.stats.std)
        row.update(validate(policy, config, backend, validation, demos.metadata.get("style"))
                   if validation.due(log.iteration, iterations - 1)
                   else dict.fromkeys(validation_columns()))
        logs.append(row)
        improved = log.return_mean >= max((row["return_mean"] for row in logs), default=-np.inf)
        with signals_deferred():  # Ctrl-C or SIGTERM during the save takes effect right after it
            _save_iteration(folder, state, policy, discriminator, logs, run_record, improved)
        if on_iteration is not None:
            on_iteration(row)
    return state


def validation_columns() -> tuple[str, ...]:
    """The log's eval_<measure> columns."""
    return tuple(f"eval_{metric}" for metric in VALIDATION_METRICS)


def validate(policy: Policy, config: Config, backend: RolloutBackend, validation: Validation,
              expert_style: str | None) -> dict[str, float]:
    """VALIDATION_METRICS of `policy` on the validation seeds and warm states, as eval_<measure>."""
    seeds = episode_seeds(Purpose.EVALUATE, VALIDATION_BASE_SEED, validation.episodes)
    evaluation = evaluate([PolicyDriver(policy, "policy", expert_style)], config, seeds, backend,
                          pool="validation")
    samples = measure_samples(evaluation.metrics)
    return {f"eval_{measure}": float(ratio(samples[measure])) for measure in VALIDATION_METRICS}


def _start_folder(folder: Path, run_record: dict[str, Any]) -> None:
    if folder.exists() and any(folder.iterdir()):
        raise RunError(f"run folder {folder} is not empty; pass --resume to continue it or choose another --out")
    folder.mkdir(parents=True, exist_ok=True)
    write_atomically(folder / "run.json", json.dumps(run_record, indent=2, sort_keys=True).encode())


def _initial_state(folder: Path, settings: RunSettings, shape: PolicyShape, demos: Any, run_record: dict[str, Any],
                   on_bc: Callable[[BcReport], None] | None) -> TrainingState:
    """BC-initialised parameters and statistics when --bc-epochs > 0, else zeros and empty statistics."""
    if settings.bc_epochs < 1:
        zeros = np.zeros(shape.parameter_count, np.float32)
        return TrainingState.start(zeros, RunningStats.empty(shape.observation_size), settings.rail)
    bc_settings = BcSettings(epochs=settings.bc_epochs, class_balance=settings.bc_class_balance,
                             seed=settings.rail.seed)
    policy, report = behaviour_cloning(demos, shape, bc_settings)
    save_policy(policy, folder / "policy_bc.npz", {**run_record, "bc_report": dataclasses.asdict(report)})
    if on_bc is not None:
        on_bc(report)
    rows = len(demos.actions)
    stats = RunningStats(rows, policy.observation_mean, policy.observation_std**2 * rows)
    return TrainingState.start(policy.parameters, stats, settings.rail)


def _save_iteration(folder: Path, state: TrainingState, policy: Policy, discriminator: Discriminator,
                    logs: list[dict[str, Any]], run_record: dict[str, Any], improved: bool) -> None:
    metadata = {**run_record, "iteration": state.iteration}
    save_policy(policy, folder / "policy_latest.npz", metadata)
    if improved:
        save_policy(policy, folder / "policy_best.npz", metadata)
    _torch_save_atomically(discriminator.state(), folder / "discriminator.pt")
    write_parquet(_log_table(logs), folder / "log.parquet", {**run_record, "kind": "training_log"})
    checkpoint = {
        "format": CHECKPOINT_FORMAT, "iteration": state.iteration,
        "parameters": torch.from_numpy(state.parameters.copy()),
        "stats": {key: torch.from_numpy(np.asarray(value).copy()) for key, value in state.stats.to_arrays().items()},
        "nu": state.nu, "best_return": state.best_return, "best_at_last_check": state.best_at_last_check,
        "rng": state.rng.bit_generator.state, "discriminator": discriminator.state(), "log": logs,
    }
    _torch_save_atomically(checkpoint, folder / "checkpoint.pt")  # last: it marks the iteration complete


def _log_table(logs: list[dict[str, Any]]) -> pa.Table:
    """The training log; eval_* columns are float64 even while every value is null."""
    table = pa.Table.from_pylist(logs)
    for name in validation_columns():
        table = table.set_column(table.schema.get_field_index(name), name, table[name].cast(pa.float64()))
    return table


def _resume(folder: Path, run_record: dict[str, Any], shape: PolicyShape,
            discriminator: Discriminator) -> tuple[TrainingState, list[dict[str, Any]]]:
    path = folder / "checkpoint.pt"
    if not path.is_file():
        raise RunError(f"nothing to resume: {path} does not exist")
    stored = json.loads((folder / "run.json").read_text())
    if stored.get("settings") != run_record["settings"] or stored.get("config") != run_record["config"]:
        raise RunError(f"run {folder} was started with other settings; resume it with the same options")
    try:
        checkpoint = torch.load(path, weights_only=True)
    except Exception as error:  # torch raises several types for corrupt or unsafe files
        raise RunError(f"checkpoint {path} is unreadable ({error})") from error
    if checkpoint.get("format") != CHECKPOINT_FORMAT:
        raise RunError(f"{path} is not a sumo-rail checkpoint")
    rng = np.random.default_rng()
    rng.bit_generator.state = checkpoint["rng"]
    stats = RunningStats.from_arrays({key: value.numpy() for key, value in checkpoint["stats"].items()})
    discriminator.load_state(checkpoint["discriminator"])
    state = TrainingState(checkpoint["iteration"], checkpoint["parameters"].numpy(), stats, checkpoint["nu"],
                          checkpoint["best_return"], checkpoint["best_at_last_check"], rng)
    if state.parameters.size != shape.parameter_count:
        raise RunError(f"checkpoint {path} holds a policy of another size")
    return state, list(checkpoint["log"])


@contextmanager
def signals_deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM until the block ends, then stop (KeyboardInterrupt), so one iteration's files stay
    consistent. (Python-level handlers: a signal mask would not do, the kernel hands it to another thread.)"""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    previous = {number: signal.signal(number, lambda caught, frame: received.append(caught))
                for number in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
    if received:
        raise KeyboardInterrupt


def _torch_save_atomically(payload: Any, path: Path) -> None:
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        torch.save(payload, temporary)
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def write_atomically(path: Path, content: bytes) -> None:
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        temporary.write_bytes(content)
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)

