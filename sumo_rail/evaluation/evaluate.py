"""Evaluate drivers (the expert, built-in drivers, saved policies) on the same held-out seeds: per episode the
paper's metrics and the on-policy comparison with the reference expert, per decision the behaviour records."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa

from sumo_rail.config import Config
from sumo_rail.drivers.expert import DEFAULT_STYLE
from sumo_rail.evaluation.driving_score import SCORE_COLUMNS, driving_scores, mean_overspeed, reference_distances
from sumo_rail.evaluation.fidelity import CONFUSION_COLUMNS, DECISION_FIELDS, RATE_COLUMNS, AgreementObserver
from sumo_rail.evaluation.protocol import Evaluation, EvaluationTask, RoadStart, Tables, unique_names
from sumo_rail.evaluation.safety import SAFETY_DECISION_FIELDS, SAFETY_MEASURES, Safety
from sumo_rail.evaluation.summary import episodes_summary
from sumo_rail.runners.backends import RolloutBackend
from sumo_rail.runners.experts import resolve_expert
from sumo_rail.runners.rollout import DriverSpec, ExpertDriver
from sumo_rail.runners.tables import EPISODE_METRICS, METRIC_COLUMNS, metrics_table
from sumo_rail.runners.video import video_name

DEFAULT_REFERENCE = ExpertDriver(DEFAULT_STYLE)
"""The expert drivers are compared with when nothing else is said."""
FIDELITY_TYPES: dict[str, pa.DataType] = {
    "reference": pa.string(), **{name: pa.int32() for name in CONFUSION_COLUMNS},
    **{name: pa.float64() for name in RATE_COLUMNS}, **{name: pa.float64() for name in SAFETY_MEASURES},
    **{name: pa.float64() for name in SCORE_COLUMNS},
}
"""Metrics columns added by the on-policy comparison with the reference expert, the safety measures and the driving
score with its parts (`sumo_rail.evaluation.driving_score`)."""
DECISIONS = "decisions"
_DECISION_KEYS: dict[str, pa.DataType] = {"policy": pa.string(), "episode": pa.int32(), "seed": pa.int64(),
                                          "step": pa.int32()}
_NUMPY_TO_ARROW: dict[type, pa.DataType] = {np.int8: pa.int8(), np.float64: pa.float64()}
DECISION_TYPES: dict[str, pa.DataType] = {**_DECISION_KEYS,
                                          **{name: _NUMPY_TO_ARROW[kind] for name, kind in DECISION_FIELDS.items()},
                                          **{name: pa.float64() for name in SAFETY_DECISION_FIELDS}}


@dataclass(frozen=True)
class Agreement:
    """Observes each decision with the reference expert (any driver): the on-policy comparison (`AgreementObserver`)."""

    reference: DriverSpec

    def create(self, config: Config, seed: int) -> AgreementObserver:
        return AgreementObserver(self.reference.create(config, seed), config.actions, self.reference.name)


def _metrics_table(metrics: pd.DataFrame) -> pa.Table:
    extra_types = {name: kind for name, kind in FIDELITY_TYPES.items() if name in metrics.columns}
    return metrics_table(metrics.to_dict("records"), extra_types)


def _decisions_table(decisions: pd.DataFrame) -> pa.Table:
    return pa.table({name: pa.array(decisions[name].to_numpy(), type=kind) for name, kind in DECISION_TYPES.items()})


EPISODES = Tables(EPISODE_METRICS, DECISIONS, ".decisions.parquet", _metrics_table, _decisions_table,
                  episodes_summary)
"""What `evaluate` writes: the metrics (with the fidelity columns where they exist) and NAME.decisions.parquet."""


def evaluate(drivers: Sequence[DriverSpec], config: Config, seeds: Sequence[int], backend: RolloutBackend,
             reference: DriverSpec | Sequence[DriverSpec] = DEFAULT_REFERENCE, pool: str = "test",
             on_episode: Callable[[int, Any], None] | None = None, video_episodes: int = 0) -> Evaluation:
    """Every driver on every seed, drivers in the given order. Episode k starts from warm state
    k mod `scenario.snapshots` of `pool`, so up to that many episodes never share a traffic state; each
    decision is compared with the reference expert: `reference` for every driver, or one per driver (a sequence,
    e.g. `recorded_reference`s). The first `video_episodes` episodes of every driver are also recorded as MP4s."""
    names = unique_names(drivers)
    warm_states = config.scenario.snapshots
    references = list(reference) if isinstance(reference, Sequence) else [reference] * len(drivers)
    tasks = [EvaluationTask(RoadStart(config, pool, k % warm_states), driver, seed,
                            (Agreement(driver_reference), Safety()), video=k < video_episodes)
             for driver, driver_reference in zip(drivers, references, strict=True) for k, seed in enumerate(seeds)]
    results = backend.run(tasks, on_result=on_episode)
    rows, decisions, videos = [], [], {}
    for index, result in enumerate(results):
        keys = {"policy": names[index // len(seeds)], "episode": index % len(seeds), "seed": result.metrics["seed"]}
        if result.video is not None:
            videos[video_name(keys["policy"], keys["episode"], keys["seed"])] = result.video
        rows.append({**keys, **result.metrics})
        steps = len(result.decisions["action"])
        decisions.append(pd.DataFrame({**{key: np.full(steps, value) for key, value in keys.items()},
                                       "step": np.arange(steps), **result.decisions}))
    metrics = pd.DataFrame(rows, columns=[*METRIC_COLUMNS, *FIDELITY_TYPES])
    decisions_frame = pd.concat(decisions, ignore_index=True)[list(DECISION_TYPES)]
    metrics[list(SCORE_COLUMNS)] = driving_scores(
        metrics, reference_distances(metrics),
        mean_overspeed(decisions_frame, metrics, config.scenario.speed_limit_mps))
    return Evaluation(metrics, decisions_frame, EPISODES, videos)


def policy_source(text: str) -> str:
    """The policy file a --policy word names ("sampled:PATH" names PATH), or the word itself."""
    name, colon, path = text.partition(":")
    return path if name == "sampled" and colon else text


def recorded_reference(driver: DriverSpec, source: str, config: Config,
                       fallback: DriverSpec = DEFAULT_REFERENCE) -> DriverSpec:
    """The expert `driver` is compared with when no expert is named: the one its policy file `source` records
    (whose demonstrations trained it; a PolicyFileError naming `source` when that file is gone or changed), else
    `fallback`."""
    recorded = getattr(driver, "expert", None)
    return resolve_expert(recorded, config, recorded_by=source) if recorded else fallback


def decisions_path(metrics_path: Path) -> Path:
    """Where the per-decision records of a metrics file go: NAME.decisions.parquet beside NAME.parquet."""
    return EPISODES.beside(metrics_path)
