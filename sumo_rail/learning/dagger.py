"""DAgger (Ross, Gordon and Bagnell, 2011), beyond the paper: the expert is a pure function of the traffic view,
so it can label the states the learner itself visits.

Round 0 is behaviour cloning on the demonstrations. Each round r >= 1 drives `episodes_per_round` training
episodes in which each decision is the expert's with probability beta_r = beta * decay^(r - 1), else the current
policy's; every visited state is labelled with the expert's action and added to the aggregated dataset, and BC
is trained again on all of it (from the same seed, so a round is a pure function of its data). The reference
for "what on-policy expert queries buy".

runs/NAME/ holds `run.json`, `dataset.parquet` (the aggregated states and labels), `policy_bc.npz` (round 0),
`policy_latest.npz`, `log.parquet` (one row per round) and `checkpoint.json` (the last complete round; written
last). An interrupted run keeps its last complete round; `resume` continues it with the same result.
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from sumo_rail.bounds import ConfigError, bounded, check_fields, given
from sumo_rail.config import Config
from sumo_rail.datasets import read_metadata, write_bytes_atomically, write_parquet
from sumo_rail.drivers.expert import DEFAULT_STYLE
from sumo_rail.drivers.policies import Policy, PolicyShape, save_policy
from sumo_rail.learning.bc import IMITATION_BC, BcReport, BcSettings, behaviour_cloning
from sumo_rail.learning.log_dagger import LOG_TEACHER, LogSeats
from sumo_rail.learning.mixture import LabelledEpisode, Mixture
from sumo_rail.learning.run_folder import (
    RunError,
    as_json,
    check_resumable,
    demos_record,
    signals_deferred,
    start_run_folder,
)
from sumo_rail.learning.validation import Validation, validate, validation_columns, with_validation_columns
from sumo_rail.runners.backends import RolloutBackend, WorkerContext
from sumo_rail.runners.experts import check_drives, demonstrations_expert, resolve_expert
from sumo_rail.runners.road_mix import road_configs
from sumo_rail.runners.rollout import DriverSpec, run_shared_episode, shared_groups
from sumo_rail.runners.tables import ACTION_TYPE, Demonstrations, provenance, read_demonstrations
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.actions import action_count
from sumo_rail.sim.observation import observation_space

CHECKPOINT_FORMAT = "sumo-rail dagger checkpoint 1"
DATASET = "dagger_dataset"
ADDED_SETTINGS = ("expert", "egos", "roads", "teacher_horizon_s", "seat_lead_s", "seat_s", "seat_zone_m")
"""Settings added since the first runs: an older run.json without them resumes with their defaults."""


@dataclass(frozen=True)
class DaggerSettings:
    """What defines a DAgger run; `resume` requires the same (except the number of rounds)."""

    demos: str = given("--demos")
    kind: str = given("network.shape", "mlp")
    hidden: int = given("network.hidden", 10)
    episodes_per_round: int = bounded(1, 100_000, default=20)
    """Episodes the mixture of policy and expert drives each round."""
    beta: float = bounded(0, 1, default=0.5)
    """Probability that the expert drives a decision in round 1."""
    beta_decay: float = bounded(0, 1, default=0.5)
    """beta_r = beta * beta_decay^(r - 1)."""
    bc: BcSettings = given("[bc]", IMITATION_BC)
    seed: int = given("--seed", 0)
    expert: str | None = given("--expert", None)
    """Who labels: a style or a policy file (`experts.resolve_expert`), or "log" (`log_dagger.LOG_TEACHER`: the
    recorded track of the scene the demonstrations were read from); None: the demonstrations' expert."""
    egos: int = bounded(1, 1000, default=1)
    """Egos per simulation: a round's episodes run K at a time in one SUMO (`DaggerTask`)."""
    roads: tuple[str, ...] = given("--roads", ())
    """Roads (scenario kinds) a round's simulations are spread over in turn, simulation j on roads[j mod len]: DAgger
    on a mix of roads. Empty: every simulation on the configured road."""
    include_failed_demos: bool = given("--include-failed", False)
    """Learn from the demonstrations' failed episodes too (`read_demonstrations`)."""
    teacher_horizon_s: float = bounded(0.5, 60, "s", default=3.0)
    """Against the log: the horizon over which a label returns the ego to the human's track (`log_teacher`)."""
    seat_lead_s: float = bounded(0, 600, "s", default=5.0)
    """Against the log: the ego takes a seat this long after the car's track begins."""
    seat_s: float = bounded(1, 600, "s", default=15.0)
    """Against the log: each round's episode in a seat lasts this long (the seat's car's track covers it)."""
    seat_zone_m: float = bounded(0, 100_000, "m", default=0.0)
    """Against the log: seats where traffic is established (`choose_seats`' zone_m; evaluate-scene's --zone-m)."""

    def __post_init__(self) -> None:
        check_fields(self, "dagger.")
        if self.bc.epochs < 1:
            raise ConfigError(f"dagger learns by behaviour cloning in every round, so bc.epochs must be at least 1 "
                              f"for it, got {self.bc.epochs}")

    def beta_of(self, round_: int) -> float:
        return self.beta * self.beta_decay ** (round_ - 1)

    def to_dict(self) -> dict[str, Any]:
        return as_json(dataclasses.asdict(self))


@dataclass(frozen=True)
class DaggerTask:
    """Episodes of a round on one road, labelled by the expert: ego j is driven by the mixture of the policy and
    the expert seeded by seeds[j] (its coin and its expert), the simulation by seeds[0]; the other egos are traffic
    to it (one seed: the single ego's episode)."""

    config: Config
    policy: Policy
    expert: DriverSpec
    beta: float
    seeds: tuple[int, ...]

    def run(self, context: WorkerContext) -> list[LabelledEpisode]:
        """Each ego's labelled episode, in ego order (egos that found no room on the road left out)."""
        mixtures = [Mixture(self.policy, self.expert.create(self.config, seed), self.beta, seed)
                    for seed in self.seeds]
        env = context.parallel_env(self.config, len(self.seeds))
        run_shared_episode(env, mixtures, self.seeds[0])  # the mixtures keep what DAgger needs
        return [mixture.episode() for mixture in mixtures if mixture.labels]


def train_dagger(folder: Path, settings: DaggerSettings, config: Config, rounds: int, backend: RolloutBackend,
                 resume: bool, validation: Validation | None = None,
                 on_round: Callable[[dict[str, Any]], None] | None = None,
                 on_episode: Callable[[int, Any], None] | None = None, log: LogSeats | None = None) -> Policy:
    """Run DAgger until `rounds` rounds after BC are done; returns the last policy. Safe to interrupt. With
    `settings.expert` "log" the log teaches in the seats `log` (read here from the demonstrations' scene when None)."""
    folder, validation = Path(folder), validation or Validation()
    observation_size = observation_space(config).shape[0]
    demos = read_demonstrations(Path(settings.demos), observation_size, settings.include_failed_demos, config.actions)
    demos_path, demos_hash = demos_record(settings.demos)
    settings = dataclasses.replace(settings, demos=demos_path)
    if settings.expert == LOG_TEACHER and log is None:
        log = LogSeats.of(demos.metadata, settings.demos, config, settings.seat_lead_s, settings.seat_s,
                          settings.teacher_horizon_s, settings.seat_zone_m)
    elif settings.expert != LOG_TEACHER:
        log = None
    # recorded drivers: NotQueryable without the log as teacher (agreement then asks the rule-based style)
    recorded = demonstrations_expert(demos.metadata, DEFAULT_STYLE if log is not None else None)
    style = recorded if log is not None else settings.expert or recorded
    expert = resolve_expert(style, config, recorded_by=None if settings.expert else settings.demos)
    if log is None:
        check_drives(expert, config)
    shape = PolicyShape(settings.kind, observation_size, settings.hidden, action_count(config.actions),
                        config.actions.decoding)
    run_record = {"settings": settings.to_dict(), "expert": LOG_TEACHER if log is not None else style, **demos_hash,
                  **provenance("dagger_run", config, settings.seed)}
    if resume:
        done, dataset, logs = _resume(folder, run_record)
        policy, _ = behaviour_cloning(dataset, shape, settings.bc)
    else:
        start_run_folder(folder, run_record)
        dataset, logs, done = demos, [], 0
        policy, report = behaviour_cloning(dataset, shape, settings.bc)
        save_policy(policy, folder / "policy_bc.npz", {**run_record, "bc_report": dataclasses.asdict(report)})
        logs.append(_row(0, 0, 0, dataset, report, 0.0, policy, config, backend, validation, expert, rounds))
        _save(folder, 0, dataset, policy, logs, run_record)
        if on_round is not None:
            on_round(logs[-1])
    for round_ in range(done + 1, rounds + 1):
        started = time.perf_counter()
        beta = settings.beta_of(round_)
        seeds = episode_seeds(Purpose.TRAIN, 10_000_000 * (settings.seed + 1) + round_ * settings.episodes_per_round,
                              settings.episodes_per_round)
        labelled = (_round_episodes(backend, road_configs(config, settings.roads), policy, expert, beta, seeds,
                                    settings.egos, on_episode) if log is None else
                    log.round_episodes(backend, policy, beta, settings.seed, round_, settings.episodes_per_round,
                                       on_episode))
        dataset = _aggregate(dataset, labelled)
        policy, report = behaviour_cloning(dataset, shape, settings.bc)
        logs.append(_row(round_, sum(len(e.labels) for e in labelled), sum(e.policy_decisions for e in labelled),
                         dataset, report, time.perf_counter() - started, policy, config, backend, validation, expert,
                         rounds, beta))
        with signals_deferred():
            _save(folder, round_, dataset, policy, logs, run_record)
        if on_round is not None:
            on_round(logs[-1])
    return policy


def _round_episodes(backend: RolloutBackend, configs: list[Config], policy: Policy, expert: DriverSpec, beta: float,
                    seeds: list[int], egos: int, on_episode: Callable[[int, Any], None] | None,
                    ) -> list[LabelledEpisode]:
    """A round's labelled episodes, `egos` seeds to a simulation, the simulations on `configs`' roads in turn."""
    groups = shared_groups(seeds, egos)
    shared = backend.run([DaggerTask(configs[j % len(configs)], policy, expert, beta, group)
                          for j, group in enumerate(groups)], on_result=on_episode)
    return [episode for episodes in shared for episode in episodes]


def _row(round_: int, decisions: int, policy_decisions: int, dataset: Demonstrations, report: BcReport,
         wall_time_s: float, policy: Policy, config: Config, backend: RolloutBackend, validation: Validation,
         expert: DriverSpec, rounds: int, beta: float = 1.0) -> dict[str, Any]:
    row = {"iteration": round_, "env_steps": decisions, "policy_decisions": policy_decisions, "beta": beta,
           "dataset_rows": len(dataset.actions), "bc_train_accuracy": report.train_accuracy,
           "bc_holdout_accuracy": report.holdout_accuracy, "wall_time_s": wall_time_s}
    due = validation.every > 0 and (round_ % validation.every == 0 or round_ == rounds)
    return row | (validate(policy, config, backend, validation, expert) if due
                  else dict.fromkeys(validation_columns()))


def _aggregate(dataset: Demonstrations, labelled: list[LabelledEpisode]) -> Demonstrations:
    """The dataset with the new episodes appended, numbered after its last episode."""
    first = int(dataset.episodes.max()) + 1 if len(dataset.episodes) else 0
    episodes = [np.full(len(e.labels), first + k) for k, e in enumerate(labelled)]
    return Demonstrations(np.concatenate([dataset.observations, *(e.observations for e in labelled)]),
                          np.concatenate([dataset.actions, *(e.labels for e in labelled)]),
                          np.concatenate([dataset.episodes, *episodes]), dataset.metadata)


def _save(folder: Path, round_: int, dataset: Demonstrations, policy: Policy, logs: list[dict[str, Any]],
          run_record: dict[str, Any]) -> None:
    size = dataset.observations.shape[1]
    table = pa.table({"episode": pa.array(dataset.episodes, pa.int32()),
                      "observation": pa.FixedSizeListArray.from_arrays(
                          pa.array(dataset.observations.astype(np.float32).ravel()), size),
                      "action": pa.array(dataset.actions, ACTION_TYPE)})
    write_parquet(table, folder / "dataset.parquet", {**run_record, "kind": DATASET, "round": round_})
    save_policy(policy, folder / "policy_latest.npz", {**run_record, "iteration": round_})
    columns = [*logs[0]]
    log = pa.table({name: pa.array([row[name] for row in logs],
                                   pa.float64() if name.startswith(("eval_", "bc_")) else None) for name in columns})
    write_parquet(log, folder / "log.parquet", {**run_record, "kind": "dagger_log"})
    write_bytes_atomically(folder / "checkpoint.json",
                           json.dumps({"format": CHECKPOINT_FORMAT, "round": round_}).encode())


def _resume(folder: Path, run_record: dict[str, Any]) -> tuple[int, Demonstrations, list[dict[str, Any]]]:
    checkpoint_path = folder / "checkpoint.json"
    added = {field.name: field.default for field in dataclasses.fields(DaggerSettings) if field.name in ADDED_SETTINGS}
    check_resumable(folder, checkpoint_path.name, run_record, as_json(added))
    try:
        checkpoint = json.loads(checkpoint_path.read_text())
        done = int(checkpoint["round"])
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise RunError(f"run {folder} has an unreadable checkpoint.json ({error})") from error
    if checkpoint.get("format") != CHECKPOINT_FORMAT:
        raise RunError(f"{checkpoint_path} is not a sumo-rail DAgger checkpoint")
    if read_metadata(folder / "dataset.parquet").get("round") != done:
        raise RunError(f"{folder / 'dataset.parquet'} does not belong to round {done} of the checkpoint")
    try:
        table = pq.read_table(folder / "dataset.parquet")
        logs = pq.read_table(folder / "log.parquet").to_pylist()
    except (pa.ArrowException, OSError) as error:
        raise RunError(f"run {folder} has an unreadable dataset or log ({error})") from error
    size = table.schema.field("observation").type.list_size
    observations = table.column("observation").combine_chunks().flatten().to_numpy().reshape(-1, size)
    dataset = Demonstrations(observations, table.column("action").to_numpy().astype(np.int64),
                             table.column("episode").to_numpy(), {})
    return done, dataset, [with_validation_columns(row) for row in logs if row["iteration"] <= done]
