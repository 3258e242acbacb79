"""Evaluate drivers (the expert, built-in drivers, saved policies) on the same held-out seeds: per episode the
paper's metrics and the on-policy comparison with the reference expert, per decision the behaviour records."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa

from sumo_rail.config import Config
from sumo_rail.datasets import write_parquet
from sumo_rail.drivers.expert import DEFAULT_STYLE, STYLES
from sumo_rail.evaluation.driving_score import SCORE_COLUMNS, driving_scores, mean_overspeed, reference_distances
from sumo_rail.evaluation.fidelity import CONFUSION_COLUMNS, DECISION_FIELDS, RATE_COLUMNS, DecisionProbe
from sumo_rail.evaluation.safety import SAFETY_DECISION_FIELDS, SAFETY_MEASURES, SafetyProbe
from sumo_rail.runners.backends import RolloutBackend, WorkerContext
from sumo_rail.runners.experts import check_drives, parse_policy, resolve_expert
from sumo_rail.runners.rollout import DriverSpec, EpisodeTask, ExpertDriver, KeepDriver, RandomDriver, probes_in_turn
from sumo_rail.runners.tables import EPISODE_METRICS, METRIC_COLUMNS, metrics_table, provenance
from sumo_rail.runners.video import FrameRecorder, encode_mp4, video_name
from sumo_rail.sim.env import HighwayEnv


def parse_driver(text: str, config: Config, expert: DriverSpec) -> DriverSpec:
    """'expert' (the given `expert`), 'expert:STYLE', 'keep', 'random', the path of a saved policy file
    (`parse_policy`), or 'sampled:PATH', that policy drawing each action from the softmax of its logits."""
    name, colon, style = text.partition(":")
    if name == "sampled" and colon:
        return parse_policy(Path(style), config, sampled=True)
    if name == "expert":
        if colon and style not in STYLES:
            raise ValueError(f"unknown expert style {style!r}; known styles: {', '.join(sorted(STYLES))}")
        driver = ExpertDriver(style) if colon else expert
        check_drives(driver, config)
        return driver
    if text == "keep":
        return KeepDriver()
    if text == "random":
        return RandomDriver()
    return parse_policy(Path(text), config)


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
class EvaluatedEpisode:
    """One evaluated episode: its metrics row (with the fidelity columns) and its per-decision records."""

    metrics: dict[str, Any]
    decisions: dict[str, np.ndarray]
    video: bytes | None = None
    """The episode as an MP4 (bird's-eye frames, one per decision), when it was asked for."""


@dataclass(frozen=True)
class EvaluationTask:
    """One episode of one driver, watched by the reference expert (any driver)."""

    episode: EpisodeTask
    reference: DriverSpec
    video: bool = False
    """Also record the episode as an MP4 of bird's-eye frames."""

    def run(self, context: WorkerContext) -> EvaluatedEpisode:
        config = self.episode.config
        probe = DecisionProbe(self.reference.create(config, self.episode.seed), config.actions)
        safety = SafetyProbe()
        recorder: FrameRecorder | None = None

        def record(env: HighwayEnv) -> FrameRecorder:
            nonlocal recorder
            recorder = FrameRecorder(env)
            return recorder

        result = self.episode.run(context, probes_in_turn(probe, safety), observer=record if self.video else None)
        video = None
        if recorder is not None:
            video = encode_mp4(recorder.frames, 1.0 / self.episode.config.env.decision_period_s)
        return EvaluatedEpisode({**result.metrics, "reference": self.reference.name, **probe.episode_columns(),
                                 **safety.episode_columns()}, probe.decision_columns() | safety.decision_columns(),
                                video)


@dataclass(frozen=True)
class Evaluation:
    """Every driver on every seed: one metrics row per episode, one decisions row per decision."""

    metrics: pd.DataFrame
    decisions: pd.DataFrame
    videos: dict[str, bytes] = field(default_factory=dict)
    """MP4 bytes of the recorded episodes by file name (`video_name`: driver, episode, seed)."""


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
    tasks = [EvaluationTask(EpisodeTask(config, driver, seed, pool=pool, warm_state=k % warm_states),
                            driver_reference, video=k < video_episodes)
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
    return Evaluation(metrics, decisions_frame, videos)


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


def unique_names(drivers: Sequence[DriverSpec]) -> list[str]:
    """Driver names, suffixed with #2, #3... where two drivers share a name."""
    names: list[str] = []
    for driver in drivers:
        name, count = driver.name, 1
        while name in names:
            count += 1
            name = f"{driver.name}#{count}"
        names.append(name)
    return names


def decisions_path(metrics_path: Path) -> Path:
    """Where the per-decision records of a metrics file go: NAME.decisions.parquet beside NAME.parquet."""
    return Path(metrics_path).with_suffix(".decisions.parquet")


def write_evaluation(evaluation: Evaluation, config: Config, seed: int, out: Path, **extra: Any) -> None:
    """The metrics table at `out` and the decisions table beside it (`decisions_path`), with provenance, atomically."""
    write_metrics(evaluation.metrics, config, seed, out, **extra)
    table = pa.table({name: pa.array(evaluation.decisions[name].to_numpy(), type=kind)
                      for name, kind in DECISION_TYPES.items()})
    write_parquet(table, decisions_path(out), provenance(DECISIONS, config, seed, metrics_file=Path(out).name,
                                                          **extra))


def write_metrics(metrics: pd.DataFrame, config: Config, seed: int, out: Path, **extra: Any) -> None:
    """The metrics table (with the fidelity columns where `metrics` has them) with provenance, atomically."""
    extra_types = {name: kind for name, kind in FIDELITY_TYPES.items() if name in metrics.columns}
    write_parquet(metrics_table(metrics.to_dict("records"), extra_types), out,
                  provenance(EPISODE_METRICS, config, seed, **extra))
