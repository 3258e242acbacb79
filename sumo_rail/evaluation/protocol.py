"""One evaluation protocol for generated episodes and recorded seats. A task (`EvaluationTask`) is a start (where the
episode begins: a warm state of the generated road, `RoadStart`, or a recorded driver's seat,
`scene_evaluation.RecordedSeatStart`), a driver (who may ask the env core for a controller of its own:
`controller_of`) and observers (recipes of observers of the env core's decisions, `sumo_rail.sim.observers`, with
what each records); it runs on any backend (`sumo_rail.runners.backends`, `ray_backend`). The measures are pure
functions of the recorded rows, and `write_evaluation` writes any evaluation's two tables (one row per episode, one
per decision beside it) with provenance, each atomically; `parse_driver` reads a --policy word for both commands.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import pandas as pd
import pyarrow as pa

from sumo_rail.config import Config
from sumo_rail.datasets import write_parquet
from sumo_rail.drivers.expert import STYLES
from sumo_rail.runners.backends import WorkerContext
from sumo_rail.runners.experts import check_drives, parse_policy
from sumo_rail.runners.rollout import (
    DriverSpec,
    ExpertDriver,
    KeepDriver,
    RandomDriver,
    controller_of,
    run_episode,
)
from sumo_rail.runners.tables import provenance
from sumo_rail.runners.video import FrameRecorder, encode_mp4
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.observers import Observer


class Start(Protocol):
    """Where an evaluated episode starts (picklable): the env it runs on and the reset options that place the ego."""

    def env(self, context: WorkerContext) -> HighwayEnv: ...

    def options(self) -> dict[str, Any]: ...


class EpisodeObserver(Observer, Protocol):
    """Watches one episode (an observer of its reset and decisions: `Moment.decisions`, what the driver saw, its
    action, the step's info; it only watches) and gives what it recorded: episode columns and per-decision columns."""

    def columns(self, env: HighwayEnv, metrics: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """After the episode (its `metrics`, on `env`): (episode columns, one entry per decision in each column)."""
        ...


class ObserverSpec(Protocol):
    """A picklable recipe of an episode's observer."""

    def create(self, config: Config, seed: int) -> EpisodeObserver: ...


@dataclass(frozen=True)
class RoadStart:
    """A generated episode: from warm state `warm_state` of `pool` (None: drawn from the seed)."""

    config: Config
    pool: str = "test"
    warm_state: int | None = None

    def env(self, context: WorkerContext) -> HighwayEnv:
        return context.env(self.config)

    def options(self) -> dict[str, Any]:
        return {"pool": self.pool, **({} if self.warm_state is None else {"warm_state": self.warm_state})}


@dataclass(frozen=True)
class EvaluatedEpisode:
    """One evaluated episode: its metrics row (the observers' episode columns with it), its per-decision records
    (the observers' columns) and, when asked for, its video."""

    metrics: dict[str, Any]
    decisions: dict[str, np.ndarray]
    video: bytes | None = None
    """The episode as an MP4 (bird's-eye frames, one per decision)."""


@dataclass(frozen=True)
class EvaluationTask:
    """One driver's episode from `start`, seeded by `seed`, watched by `observers` (and filmed with `video`): the unit
    of work of every evaluation."""

    start: Start
    driver: DriverSpec
    seed: int
    observers: tuple[ObserverSpec, ...] = ()
    video: bool = False
    """Also record the episode as an MP4 of bird's-eye frames (`sumo_rail.runners.video.FrameRecorder`)."""

    def run(self, context: WorkerContext) -> EvaluatedEpisode:
        env = self.start.env(context)
        config = env.config
        observers = [spec.create(config, self.seed) for spec in self.observers]
        options = {"controller": controller_of(self.driver), **self.start.options()}  # a start may fix the seat's
        driver = self.driver.create(config, self.seed)
        recorder = FrameRecorder(env) if self.video else None
        watched: list[Observer] = [*observers, *([recorder] if recorder is not None else [])]
        with contextlib.ExitStack() as watching:
            for observer in watched:
                watching.enter_context(env.watching(observer))
            result = run_episode(env, driver, self.seed, options=options)
        metrics, decisions = dict(result.metrics), {}
        for observer in observers:
            episode, per_decision = observer.columns(env, result.metrics)
            metrics.update(episode)
            decisions.update(per_decision)
        video = None if recorder is None else encode_mp4(recorder.frames, 1.0 / config.env.decision_period_s)
        return EvaluatedEpisode(metrics, decisions, video)


@dataclass(frozen=True)
class Tables:
    """What an evaluation writes: the provenance kinds of its episode and decision tables, the decision table's
    suffix beside the episodes' file, and how each frame becomes an Arrow table."""

    episodes: str
    decisions: str
    suffix: str
    episode_table: Callable[[pd.DataFrame], pa.Table]
    decision_table: Callable[[pd.DataFrame], pa.Table]
    summary: Callable[[Evaluation, Config, str | None, str | None], str]
    """The tables a reader compares the drivers with (`summarise`)."""

    def beside(self, out: Path) -> Path:
        """Where the decisions of the episodes at `out` go: NAME.SUFFIX.parquet beside NAME.parquet."""
        return Path(out).with_suffix(self.suffix)


@dataclass(frozen=True)
class Evaluation:
    """Every driver's episodes: one metrics row per episode, one row per decision, what they are (`tables`)."""

    metrics: pd.DataFrame
    decisions: pd.DataFrame
    tables: Tables
    videos: dict[str, bytes] = field(default_factory=dict)
    """MP4 bytes of the recorded episodes by file name (`video_name`: driver, episode, seed)."""


def write_evaluation(evaluation: Evaluation, config: Config, seed: int, out: Path, **extra: Any) -> None:
    """The metrics table at `out` and the decisions beside it (`Tables.beside`), with provenance, each atomically."""
    tables = evaluation.tables
    write_parquet(tables.episode_table(evaluation.metrics), out, provenance(tables.episodes, config, seed, **extra))
    write_parquet(tables.decision_table(evaluation.decisions), tables.beside(out),
                  provenance(tables.decisions, config, seed, metrics_file=Path(out).name, **extra))


def summarise(evaluation: Evaluation, config: Config, reference: str | None = None, expert: str | None = None) -> str:
    """The tables a reader compares an evaluation's drivers with, as text (its kind's `Tables.summary`): differences to
    the driver `reference` (default: the first) and distances to the expert named `expert`, where its kind has them."""
    return evaluation.tables.summary(evaluation, config, reference, expert)


def plain_table(frame: pd.DataFrame) -> pa.Table:
    """A frame as an Arrow table of pandas' own types, without its index."""
    return pa.Table.from_pandas(frame, preserve_index=False)


NAMED_DRIVERS: dict[str, DriverSpec] = {"keep": KeepDriver(), "random": RandomDriver()}
"""The drivers a --policy word names on any road."""


def parse_driver(text: str, config: Config, expert: DriverSpec,
                 named: Mapping[str, DriverSpec] = NAMED_DRIVERS, words: Sequence[str] = ()) -> DriverSpec:
    """'expert' (the given `expert`), 'expert:STYLE', a name of `named` ('keep', 'random'; a recorded seat's
    'sumo-idm'), the path of a saved policy file (`parse_policy`), or 'sampled:PATH', that policy drawing each action
    from the softmax of its logits. Any other word (a path with nothing there too) is a ValueError listing the words
    of `named` and `words` (those named only when asked for)."""
    name, colon, style = text.partition(":")
    if name == "sampled" and colon:
        return parse_policy(existing_policy_path(style, text, [*named, *words]), config, sampled=True)
    if name == "expert":
        if colon and style not in STYLES:
            raise ValueError(f"unknown expert style {style!r}; known styles: {', '.join(sorted(STYLES))}")
        driver = ExpertDriver(style) if colon else expert
        check_drives(driver, config)
        return driver
    if text in named:
        return named[text]
    return parse_policy(existing_policy_path(text, text, [*named, *words]), config)


def existing_policy_path(path: str, text: str, named: Sequence[str]) -> Path:
    """`path` if a file or folder is there (`parse_policy` names it if it is no policy file); otherwise a ValueError
    (a bad --policy word, not a missing file) listing the words `text` could have been."""
    if not Path(path).exists():
        words = ", ".join(["expert", "expert:STYLE", *dict.fromkeys(named), "PATH", "sampled:PATH"])
        raise ValueError(f"{text!r} is neither a driver word ({words}) nor an existing policy file")
    return Path(path)


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
