"""A scene folder read back and checked (the contract is `scene`): its meta, tracks, split and network."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from sumo_rail.config import Config
from sumo_rail.datasets import DatasetError, check_file, file_sha256, read_table
from sumo_rail.recordings.importing import SCENE_FILES, SPLITS
from sumo_rail.recordings.scene import TRACK_COLUMNS, SceneMeta
from sumo_rail.recordings.scene_observations import SceneRoad, scene_road
from sumo_rail.recordings.tracks import RecordingUsageError


@dataclass(frozen=True)
class Scene:
    """A scene folder read back: its meta, tracks (`TRACK_COLUMNS`), split and network file."""

    folder: Path
    meta: SceneMeta
    tracks: pd.DataFrame
    split: pd.DataFrame
    network: Path

    def track(self, vehicle: str) -> pd.DataFrame:
        """One vehicle's rows in time order; DatasetError when the scene has no such vehicle."""
        rows = self.tracks[self.tracks["vehicle_id"] == vehicle]
        if rows.empty:
            raise DatasetError(f"scene {self.folder} has no vehicle {vehicle!r}")
        return rows.sort_values("time_s")


def read_scene(folder: Path) -> Scene:
    """The scene folder `folder`; RecordingUsageError naming the missing or unreadable file, or the network (the
    user's, for FCD) whose content has changed since the scene was imported on it (scene.json holds its sha256)."""
    try:
        for name in SCENE_FILES:
            check_file(folder / name, "scene file")
        meta = SceneMeta(**json.loads((folder / "scene.json").read_text()))
        network = Path(meta.network) if Path(meta.network).is_absolute() else folder / meta.network
        check_file(network, "scene network")
        tracks = read_table(folder / "tracks.parquet", columns=list(TRACK_COLUMNS)).to_pandas()
        split = read_table(folder / "split.parquet", columns=["vehicle_id", "split"]).to_pandas()
    except (DatasetError, json.JSONDecodeError, TypeError, KeyError, UnicodeDecodeError) as error:
        raise RecordingUsageError(f"{folder} is not a readable scene folder ({error})") from error
    recorded = meta.sources.get(meta.network)
    if recorded is not None and recorded != file_sha256(network):
        raise RecordingUsageError(f"the network {network} has changed since the scene {folder} was imported on it "
                                  f"(its content hash differs); use the scene with the network it was imported on, "
                                  f"or import the recording again")
    return Scene(folder, meta, tracks, split, network)


def check_scene(scene: Scene, config: Config, split: str) -> SceneRoad:
    """The scene's road; RecordingUsageError when the scene cannot give this configuration's observation (another
    lane count, a road that is not one straight edge), its road's speed limit is not this configuration's
    (`check_speed_limit`) or `split` names no vehicle."""
    if split not in SPLITS:
        raise RecordingUsageError(f"unknown split {split!r}; known: {', '.join(SPLITS)}")
    try:
        road = scene_road(scene.network)
    except DatasetError as error:
        raise RecordingUsageError(str(error)) from error
    if road.lanes != config.scenario.lanes:
        raise RecordingUsageError(f"the scene {scene.folder} has {road.lanes} lanes and the observation "
                                  f"scenario.lanes={config.scenario.lanes}; pass --set scenario.lanes={road.lanes}")
    check_speed_limit(road.speed_limit_mps, config, f"the road of the scene {scene.folder}")
    if not (scene.split["split"] == split).any():
        raise RecordingUsageError(f"the scene {scene.folder} has no vehicle in the {split} split")
    return road


SPEED_TOLERANCE_MPS = 0.005
"""Speeds this close are one (a network file writes speeds to 0.01 m/s)."""


def check_speed_limit(road_limit_mps: float, config: Config, what: str) -> None:
    """RecordingUsageError unless `config` drives at the speed limit `road_limit_mps` [m/s] of the road `what` (a
    scene's, named in the sentence): scenario.speed_limit_mps is that limit (the generated roads' and the driving
    score's), and env.v_max_mps (the highest set-point, the observation's speed scale) is not below it, so that the
    set-points and the ego can reach the recorded drivers' speeds."""
    limit, top, road = config.scenario.speed_limit_mps, config.env.v_max_mps, road_limit_mps
    fixes = ([] if abs(limit - road) <= SPEED_TOLERANCE_MPS else [f"scenario.speed_limit_mps={road:g}"]) + (
        [] if top >= road - SPEED_TOLERANCE_MPS else [f"env.v_max_mps={road:g}"])
    if fixes:
        raise RecordingUsageError(f"{what} has a speed limit of {road:g} m/s and this configuration has "
                                  f"scenario.speed_limit_mps={limit:g} and env.v_max_mps={top:g} (the highest "
                                  f"set-point, which may not be below the limit); pass --set {' --set '.join(fixes)}")


def scene_sources(scene: Scene) -> dict[str, str]:
    """The scene's own files (and its network) -> sha256 of their bytes."""
    paths = [scene.folder / name for name in SCENE_FILES] + [scene.network]
    return {str(path.resolve()): file_sha256(path) for path in paths}
