"""Export recorded demonstrations to Minari, the Farama Foundation's format for offline datasets (optional extra
`sumo-rail[minari]`).

A Minari episode holds T actions and T + 1 observations: the observation after the last decision too. The
demonstrations file keeps the T observations the expert acted on; the export recovers the last one by replaying
each episode from its seed with the recorded actions, which reproduces it bit for bit (the replay checks every
recorded observation on the way and refuses to export an episode that does not replay identically, e.g. under
another SUMO version). The dataset records the environment spec (`sumo_rail/Highway-v0` with the recording's
config), so `dataset.recover_environment()` rebuilds the environment.

Minari writes under $MINARI_DATASETS_PATH (default ~/.minari/datasets); `root` overrides it. The dataset is
built in a temporary folder beside its destination and moved into place when complete.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import shutil
import tempfile
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from sumo_rail import ENV_ID
from sumo_rail.config import Config
from sumo_rail.datasets import DatasetError, read_metadata, sumo_version
from sumo_rail.runners.experts import RECORDED_SCENE
from sumo_rail.runners.tables import DEMONSTRATIONS, read_demonstrations

INSTALL_HINT = "pip install 'sumo-rail[minari]'"


class ExportError(RuntimeError):
    """The export cannot be done (message is one sentence)."""


@dataclass(frozen=True)
class ExportSummary:
    """What was exported, and where."""

    dataset_id: str
    episodes: int
    steps: int
    path: Path


@dataclass(frozen=True)
class RecordedEpisode:
    """One episode of a demonstrations file, in step order."""

    seed: int
    observations: np.ndarray
    """Shape (T, n) float32: what the expert acted on."""
    actions: np.ndarray
    rewards: np.ndarray
    terminated: bool
    truncated: bool


def read_episodes(path: Path) -> tuple[Config, list[RecordedEpisode]]:
    """The recording's config and its episodes (DatasetError if the file is not a demonstrations file, is damaged as
    `read_demonstrations` says, or holds demonstrations read from a recorded scene, whose episodes the env cannot
    replay)."""
    metadata = read_metadata(path)
    if metadata.get("kind") != DEMONSTRATIONS:
        raise DatasetError(f"{path} holds {metadata.get('kind')!r} data, not demonstrations")
    scene = metadata.get(RECORDED_SCENE)
    if isinstance(scene, dict):
        raise DatasetError(f"{path} were read from the recorded scene {scene.get('folder')}: its episodes have no "
                           f"seed the env could replay to recover each one's last observation, which a Minari "
                           f"dataset holds, so only record-expert's demonstrations can be exported")
    read_demonstrations(path)  # the checks every reader of demonstrations makes (observations' shape, actions)
    try:
        table = pq.read_table(path, columns=["episode", "step", "episode_seed", "observation", "action", "reward",
                                             "terminated", "truncated"]).sort_by([("episode", "ascending"),
                                                                                  ("step", "ascending")])
    except (pa.ArrowException, OSError, KeyError) as error:
        raise DatasetError(f"{path} is not a readable demonstrations file ({error})") from error
    size = table.schema.field("observation").type.list_size
    observations = table.column("observation").combine_chunks().flatten().to_numpy().reshape(-1, size)
    columns = {name: table.column(name).to_numpy() for name in ("episode", "episode_seed", "action", "reward",
                                                                 "terminated", "truncated")}
    starts = np.flatnonzero(np.r_[True, np.diff(columns["episode"]) != 0])
    ends = np.r_[starts[1:], len(columns["episode"])]
    episodes = [RecordedEpisode(int(columns["episode_seed"][a]), observations[a:b].astype(np.float32),
                                columns["action"][a:b].astype(np.int64), columns["reward"][a:b].astype(np.float64),
                                bool(columns["terminated"][a]), bool(columns["truncated"][a]))
                for a, b in zip(starts, ends, strict=True)]
    return Config.from_dict(metadata["config"]), episodes


def final_observations(config: Config, episodes: list[RecordedEpisode],
                       on_episode: Callable[[int], None] | None = None) -> list[np.ndarray]:
    """The observation after each episode's last decision, by replaying it (ExportError if it differs)."""
    from sumo_rail.sim.env import HighwayEnv

    finals = []
    env = HighwayEnv(config)
    try:
        for index, episode in enumerate(episodes):
            observation, _ = env.reset(seed=episode.seed, options={"pool": "train"})
            for step, action in enumerate(episode.actions):
                if not np.array_equal(observation, episode.observations[step]):
                    raise ExportError(f"episode {index} does not replay identically at decision {step} (it was "
                                      f"recorded with another SUMO or sumo-rail than SUMO {sumo_version()} here), so "
                                      f"its last observation cannot be recovered")
                observation, *_ = env.step(int(action))
            finals.append(observation)
            if on_episode is not None:
                on_episode(index)
    finally:
        env.close()
    return finals


def export_minari(demos: Path, dataset_id: str, root: Path | None = None, overwrite: bool = False,
                  on_episode: Callable[[int], None] | None = None,
                  hold: Callable[[Path], None] | None = None) -> ExportSummary:
    """Write the demonstrations at `demos` as the Minari dataset `dataset_id` ("[namespace/]name-vN"); `hold` is
    called with the dataset's folder before anything is written (the command's output lock). ExportError for a
    datasets folder that cannot be written, DatasetError for demonstrations that cannot be exported."""
    minari = _import_minari()
    from minari.data_collector import EpisodeBuffer
    from minari.dataset.minari_dataset import parse_dataset_id

    try:
        parse_dataset_id(dataset_id)
    except ValueError as error:
        raise ExportError(f"{dataset_id!r} is not a Minari dataset id such as 'sumo-rail/expert-v0' ({error})") \
            from error
    config, episodes = read_episodes(demos)
    with _datasets_root(root) as target_root:
        target = target_root / dataset_id
        if hold is not None:
            hold(target)
        if target.exists() and not overwrite:
            raise ExportError(f"the Minari dataset {dataset_id} already exists in {target_root}; pass --overwrite to "
                              f"replace it")
        try:
            scratch = Path(tempfile.mkdtemp(prefix=".sumo-rail-minari-", dir=target_root))
        except OSError as error:
            raise ExportError(f"cannot write into the Minari datasets folder {target_root}: "
                              f"{error.strerror or error}") from error
        try:
            finals = final_observations(config, episodes, on_episode)
            buffers = [EpisodeBuffer(id=k, seed=e.seed, observations=np.concatenate([e.observations, final[None]]),
                                     actions=e.actions, rewards=list(e.rewards),
                                     terminations=[False] * (len(e.actions) - 1) + [e.terminated],
                                     truncations=[False] * (len(e.actions) - 1) + [e.truncated])
                       for k, (e, final) in enumerate(zip(episodes, finals, strict=True))]
            import gymnasium

            spec = dataclasses.replace(gymnasium.spec(ENV_ID), kwargs={"config": config.to_dict()})
            with _environment("MINARI_DATASETS_PATH", str(scratch)), warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # advice on unset authors, permalinks, eval envs
                minari.create_dataset_from_buffers(
                    dataset_id, buffers, env=spec, algorithm_name="sumo-rail rule-based expert", author="sumo-rail",
                    description=f"sumo-rail expert demonstrations exported from {Path(demos).name}",
                    data_format="arrow")
            if target.exists():
                shutil.rmtree(target)
            target.parent.mkdir(parents=True, exist_ok=True)
            for metadata in scratch.glob("*/namespace_metadata.json"):  # a new namespace's description
                destination = target_root / metadata.relative_to(scratch)
                if not destination.exists():
                    os.replace(metadata, destination)
            os.replace(scratch / dataset_id, target)
        except OSError as error:
            raise ExportError(f"cannot write the Minari dataset {dataset_id} into {target_root}: "
                              f"{error.strerror or error}") from error
        finally:
            shutil.rmtree(scratch, ignore_errors=True)
    return ExportSummary(dataset_id, len(episodes), int(sum(len(e.actions) for e in episodes)), target)


def _import_minari() -> Any:
    try:
        import minari
    except ImportError as error:
        raise ExportError(f"the Minari export needs minari, which is not installed; install it with {INSTALL_HINT}") \
            from error
    return minari


@contextlib.contextmanager
def _datasets_root(root: Path | None) -> Iterator[Path]:
    """Minari's datasets folder: `root`, else $MINARI_DATASETS_PATH, else ~/.minari/datasets (created); absolute,
    as Minari joins a relative datasets folder to the paths it has already joined to it."""
    path = (Path(root) if root is not None else Path(os.environ.get("MINARI_DATASETS_PATH")
                                                     or Path.home() / ".minari" / "datasets")).absolute()
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ExportError(f"cannot create the Minari datasets folder {path}: {error.strerror or error}") from error
    yield path


@contextlib.contextmanager
def _environment(name: str, value: str) -> Iterator[None]:
    previous = os.environ.get(name)
    os.environ[name] = value
    try:
        yield
    finally:
        if previous is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = previous
