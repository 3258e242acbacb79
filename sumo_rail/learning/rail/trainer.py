"""A training run in a folder: BC initialisation, RAIL iterations, atomic checkpoints, resume, the training log.

runs/NAME/ holds `run.json` (settings, config, provenance), `checkpoint.pt` (everything to continue exactly;
written with torch.save and read with `weights_only=True`, so loading never runs code), `policy_bc.npz`,
`policy_latest.npz`, `policy_best.npz` (by mean discriminator return), `discriminator.pt` and `log.parquet`
(one row per iteration; every `Validation.every` iterations it also holds the policy's mean episode metrics on
validation seeds and the 95% interval of its agreement with the expert, `eval_*` columns, null otherwise). Every
file is replaced atomically after each iteration, so an interrupted run keeps its last complete iteration and
`--resume` continues from it bit for bit.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import torch

from sumo_rail.config import Config
from sumo_rail.datasets import DatasetError, describe, write_failure, write_parquet, written_together
from sumo_rail.drivers.expert import DEFAULT_STYLE
from sumo_rail.drivers.policies import Policy, PolicyShape, save_policy
from sumo_rail.learning.bc import IMITATION_BC, BcReport, BcSettings, behaviour_cloning
from sumo_rail.learning.rail.discriminator import Discriminator, DiscriminatorSettings
from sumo_rail.learning.rail.iteration import RailSettings, TrainingState, run_iteration
from sumo_rail.learning.rail.normalize import RunningStats
from sumo_rail.learning.rail.seat_rollouts import InSeats, rail_seats
from sumo_rail.learning.run_folder import (
    RunError,
    as_json,
    check_resumable,
    demos_record,
    load_checkpoint,
    save_tensors,
    signals_deferred,
    start_run_folder,
)
from sumo_rail.learning.validation import Validation, validate, validation_columns, with_validation_columns
from sumo_rail.runners.backends import RolloutBackend
from sumo_rail.runners.experts import demonstrations_expert, resolve_expert
from sumo_rail.runners.tables import provenance, read_demonstrations
from sumo_rail.sim.actions import action_count
from sumo_rail.sim.observation import observation_space

CHECKPOINT_FORMAT = "sumo-rail checkpoint 1"


@dataclass(frozen=True)
class RunSettings:
    """What defines a run, every setting of its sections (stored whole in run.json); `--resume` requires the same
    (except the number of iterations)."""

    demos: str
    kind: str
    """The network's shape (network.shape)."""
    hidden: int
    rail: RailSettings
    discriminator: DiscriminatorSettings
    bc: BcSettings = IMITATION_BC
    """The behaviour cloning that initialises the policy (bc.epochs 0: none, zero weights); its seed is the run's."""
    include_failed_demos: bool = False
    """Learn from the demonstrations' failed episodes too (`read_demonstrations`)."""

    def to_dict(self) -> dict[str, Any]:
        return as_json(dataclasses.asdict(self))


def train(folder: Path, settings: RunSettings, config: Config, iterations: int, backend: RolloutBackend,
          resume: bool, validation: Validation | None = None,
          on_bc: Callable[[BcReport], None] | None = None,
          on_iteration: Callable[[dict[str, Any]], None] | None = None,
          on_rollout: Callable[[int, Any], None] | None = None,
          on_start: Callable[[int], None] | None = None, in_seats: InSeats | None = None) -> TrainingState:
    """Train until `iterations` iterations are done; returns the final state. Safe to interrupt at any time.

    `on_bc` receives the behaviour-cloning report (new runs with bc.epochs > 0); `on_iteration` each iteration's
    log row (IterationLog fields, wall_time_s and eval_* metrics); `on_rollout` each rollout as it arrives;
    `on_start` the iterations already done (those of the resumed run, else 0) before the first new one. With
    rail.rollout_seats the rollouts drive the train-split seats `in_seats` (read here from the demonstrations' scene
    when None; `seat_rollouts.rail_seats`)."""
    folder, validation = Path(folder), validation or Validation()
    observation_size = observation_space(config).shape[0]
    demos = read_demonstrations(Path(settings.demos), observation_size, settings.include_failed_demos, config.actions)
    demos_path, demos_hash = demos_record(settings.demos)
    settings = dataclasses.replace(settings, demos=demos_path)
    shape = PolicyShape(settings.kind, observation_size, settings.hidden, action_count(config.actions),
                        config.actions.decoding)
    expert = demonstrations_expert(demos.metadata, recorded_stand_in=DEFAULT_STYLE)  # recorded: agreement asks it
    run_record = {"settings": settings.to_dict(), "expert": expert, **demos_hash,
                  **provenance("training_run", config, settings.rail.seed)}
    expert_stats = RunningStats.of(demos.observations)
    discriminator = Discriminator(observation_size, expert_stats.mean.copy(), expert_stats.std.copy(),
                                  settings.discriminator, shape.actions)
    asked = resolve_expert(expert, config, recorded_by=settings.demos)  # checked before any work
    in_seats = in_seats or rail_seats(settings.rail, demos.metadata, settings.demos, config)
    if resume:
        state, logs = _resume(folder, run_record, shape, discriminator)
    else:
        start_run_folder(folder, run_record)
        state, logs = _initial_state(folder, settings, shape, demos, run_record, on_bc), []
    if on_start is not None:
        on_start(state.iteration)
    while state.iteration < iterations:
        started = time.perf_counter()
        log = run_iteration(state, shape, config, settings.rail, discriminator, demos, backend, on_rollout, asked,
                            in_seats)
        row = {**dataclasses.asdict(log), "wall_time_s": time.perf_counter() - started}
        policy = Policy(shape, state.parameters, state.stats.mean, state.stats.std)
        row.update(validate(policy, config, backend, validation, asked)
                   if validation.due(log.iteration, iterations - 1)
                   else dict.fromkeys(validation_columns()))
        logs.append(row)
        improved = log.return_mean >= max((row["return_mean"] for row in logs), default=-np.inf)
        with signals_deferred():  # Ctrl-C or SIGTERM during the save takes effect right after it
            _save_iteration(folder, state, policy, discriminator, logs, run_record, improved)
        if on_iteration is not None:
            on_iteration(row)
    return state


def _initial_state(folder: Path, settings: RunSettings, shape: PolicyShape, demos: Any, run_record: dict[str, Any],
                   on_bc: Callable[[BcReport], None] | None) -> TrainingState:
    """BC-initialised parameters and statistics when bc.epochs > 0, else zeros and the demonstrations'
    statistics (BC's are the demonstrations' too, so a frozen normaliser always holds the expert's)."""
    if settings.bc.epochs < 1:
        zeros = np.zeros(shape.parameter_count, np.float32)
        return TrainingState.start(zeros, RunningStats.of(demos.observations), settings.rail)
    policy, report = behaviour_cloning(demos, shape, dataclasses.replace(settings.bc, seed=settings.rail.seed))
    save_policy(policy, folder / "policy_bc.npz", {**run_record, "bc_report": dataclasses.asdict(report)})
    if on_bc is not None:
        on_bc(report)
    rows = len(demos.actions)
    stats = RunningStats(rows, policy.observation_mean, policy.observation_std**2 * rows)
    return TrainingState.start(policy.parameters, stats, settings.rail)


def _save_iteration(folder: Path, state: TrainingState, policy: Policy, discriminator: Discriminator,
                    logs: list[dict[str, Any]], run_record: dict[str, Any], improved: bool) -> None:
    """Write the iteration's files as one: all are written aside first and renamed into place only when every write
    succeeded, checkpoint.pt last. A failed write (a full disk) leaves the previous iteration's files as they were."""
    metadata = {**run_record, "iteration": state.iteration}
    checkpoint = {
        "format": CHECKPOINT_FORMAT, "iteration": state.iteration,
        "parameters": torch.from_numpy(state.parameters.copy()),
        "stats": {key: torch.from_numpy(np.asarray(value).copy()) for key, value in state.stats.to_arrays().items()},
        "nu": state.nu, "best_return": state.best_return, "best_at_last_check": state.best_at_last_check,
        "rng": state.rng.bit_generator.state, "discriminator": discriminator.state(), "log": logs,
    }
    try:
        with written_together(folder) as staged:
            save_policy(policy, staged.path(folder / "policy_latest.npz"), metadata)
            if improved:
                save_policy(policy, staged.path(folder / "policy_best.npz"), metadata)
            save_tensors(discriminator.state(), staged.path(folder / "discriminator.pt"))
            write_parquet(_log_table(logs), staged.path(folder / "log.parquet"), {**run_record, "kind": "training_log"})
            save_tensors(checkpoint, staged.path(folder / "checkpoint.pt"))  # last: it marks the iteration complete
    except (OSError, DatasetError) as error:
        kept = (f"keeps iteration {state.iteration - 1}, the last complete one" if state.iteration > 1
                else "holds no complete iteration yet")
        raise RunError(f"cannot save iteration {state.iteration} in {folder} ({write_failure(error)}); the folder "
                       f"{kept}: make room and continue with --resume") from error


def _log_table(logs: list[dict[str, Any]]) -> pa.Table:
    """The training log; eval_* columns are float64 even while every value is null."""
    table = pa.Table.from_pylist(logs)
    for name in validation_columns():
        table = table.set_column(table.schema.get_field_index(name), name, table[name].cast(pa.float64()))
    return table


def _resume(folder: Path, run_record: dict[str, Any], shape: PolicyShape,
            discriminator: Discriminator) -> tuple[TrainingState, list[dict[str, Any]]]:
    """The state and log of the last complete iteration; reads run.json and checkpoint.pt and writes nothing. A
    damaged, foreign or mismatched file is a RunError naming it."""
    path = folder / "checkpoint.pt"
    defaults = {"rail": dataclasses.asdict(RailSettings()),
                "discriminator": dataclasses.asdict(DiscriminatorSettings())}
    check_resumable(folder, path.name, run_record, as_json(defaults))
    checkpoint = load_checkpoint(path, CHECKPOINT_FORMAT)
    try:
        rng = np.random.default_rng()
        rng.bit_generator.state = checkpoint["rng"]
        stats = RunningStats.from_arrays({key: value.numpy() for key, value in checkpoint["stats"].items()})
        discriminator.load_state(checkpoint["discriminator"])
        state = TrainingState(int(checkpoint["iteration"]), checkpoint["parameters"].numpy(), stats, checkpoint["nu"],
                              checkpoint["best_return"], checkpoint["best_at_last_check"], rng)
        logs = [with_validation_columns(dict(row)) for row in checkpoint["log"]]
    except KeyError as error:
        raise RunError(f"checkpoint {path} lacks its entry {error}") from error
    except (TypeError, ValueError, AttributeError, RuntimeError) as error:
        raise RunError(f"checkpoint {path} is inconsistent ({describe(error)})") from error
    if state.parameters.size != shape.parameter_count:
        raise RunError(f"checkpoint {path} holds a policy of another size")
    if len(logs) != state.iteration:
        raise RunError(f"checkpoint {path} is inconsistent: {len(logs)} log rows for {state.iteration} iterations")
    return state, logs
