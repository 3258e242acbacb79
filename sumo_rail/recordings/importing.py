"""`sumo-rail import-recording`: a highD, NGSIM or FCD recording -> a scene folder (`scene` documents the layout).

Everything a user can get wrong in the command (files, options, columns, the network: for FCD one straight edge along
+x, as `recorded-demos` and `evaluate-scene` take) is checked by `check_import` before any work
(`RecordingUsageError`); what is wrong in the data is found while reading (`RecordingDataError`). The folder's files
are written together: on any error none of them is. scene.json pins every file read by its sha256.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa

from sumo_rail.config import Config
from sumo_rail.datasets import (
    DatasetError,
    check_file,
    check_output_folder,
    file_sha256,
    write_parquet,
    written_together,
)
from sumo_rail.recordings import fcd, highd, ngsim
from sumo_rail.recordings.road import NetworkLanes, build_road, read_lanes
from sumo_rail.recordings.scene import SceneMeta
from sumo_rail.recordings.scene_observations import scene_road
from sumo_rail.recordings.tracks import Recording, RecordingDataError, RecordingUsageError, kept_tracks, track_table
from sumo_rail.runners.tables import provenance

FORMATS = ("highd", "ngsim", "fcd")
SPLITS = ("train", "validation", "test")
SCENE_FILES = ("tracks.parquet", "split.parquet", "scene.json")


@dataclass(frozen=True)
class ImportSettings:
    """What to import and how (the options of `sumo-rail import-recording`)."""

    format: str
    files: tuple[Path, ...]
    out: Path
    direction: str = "lower"
    """highD: the driving direction kept ("upper" or "lower")."""
    site: str = "us-101"
    """NGSIM: the site ("us-101" or "i-80"), which fixes the main lanes."""
    network: Path | None = None
    """FCD: the SUMO network the positions refer to."""
    vehicles: tuple[str, ...] = ()
    """Source vehicle ids to keep (empty: all)."""
    section_m: tuple[float, float] | None = None
    """Keep only the rows whose front x [m] (scene coordinates) lies in this range."""
    split_seed: int = 0
    test_share: float = 0.2
    validation_share: float = 0.1
    hold_out_after_s: float | None = None
    """Hold out by time: the vehicles that enter at or after this time [s] are the test set."""
    overwrite: bool = False


@dataclass(frozen=True)
class ImportSummary:
    """What an import kept and dropped."""

    kept: int
    dropped: dict[str, str]
    notes: list[str]
    split_counts: dict[str, int]


def check_scene_output(out: Path, overwrite: bool) -> None:
    """RecordingUsageError unless a scene folder can be written to `out` (without `overwrite`: holding no scene)."""
    try:
        check_output_folder(out)
    except DatasetError as error:
        raise RecordingUsageError(str(error)) from error
    existing = [name for name in (*SCENE_FILES, "road.net.xml") if (out / name).exists()]
    if existing and not overwrite:
        raise RecordingUsageError(f"{out} already holds a scene ({existing[0]}); pass --overwrite to replace it")


def check_import(settings: ImportSettings) -> NetworkLanes | None:
    """RecordingUsageError for anything wrong before work starts; returns the FCD network's lanes (else None)."""
    if settings.format not in FORMATS:
        raise RecordingUsageError(f"unknown format {settings.format!r}; known: {', '.join(FORMATS)}")
    if not settings.files:
        raise RecordingUsageError("no recording files given")
    if (settings.network is not None) != (settings.format == "fcd"):
        raise RecordingUsageError("--network is needed for --format fcd and only for it")
    try:
        for path in settings.files:
            check_file(path, "recording file")
    except DatasetError as error:
        raise RecordingUsageError(str(error)) from error
    check_scene_output(settings.out, settings.overwrite)
    if not 0 <= settings.test_share < 1 or not 0 <= settings.validation_share < 1 or (
            settings.test_share + settings.validation_share >= 1):
        raise RecordingUsageError("--test-share and --validation-share must be in [0, 1) and leave vehicles to train")
    if settings.section_m is not None and not settings.section_m[0] < settings.section_m[1]:
        raise RecordingUsageError(f"--section START:END needs START < END, got {settings.section_m}")
    files = list(settings.files)
    if settings.format == "highd":
        highd.check_headers(files)
    elif settings.format == "ngsim":
        ngsim.check_headers(files)
    else:
        fcd.check_headers(files)
        try:
            lanes = read_lanes(settings.network)  # type: ignore[arg-type]
            scene_road(settings.network)  # type: ignore[arg-type]  # what recorded-demos and evaluate-scene take
            return lanes
        except DatasetError as error:
            raise RecordingUsageError(str(error)) from error
    return None


def source_files(settings: ImportSettings) -> list[Path]:
    """Every file the import reads: the files given, and for highD the rest of the recording's three."""
    return list(highd.recording_files(list(settings.files))) if settings.format == "highd" else list(settings.files)


def read_recording(settings: ImportSettings, network: NetworkLanes | None) -> Recording:
    """The recording the settings name, read by its format's reader."""
    files = list(settings.files)
    if settings.format == "highd":
        return highd.read(files, settings.direction)
    if settings.format == "ngsim":
        return ngsim.read(files, settings.site)
    return fcd.read(files, network, settings.network)  # type: ignore[arg-type]


def selected(recording: Recording, settings: ImportSettings) -> pd.DataFrame:
    """The rows of the chosen vehicles within the chosen section; RecordingDataError for a vehicle not recorded."""
    tracks = recording.tracks
    if settings.vehicles:
        missing = sorted(set(settings.vehicles) - set(tracks["source_id"].unique()))
        if missing:
            raise RecordingDataError(f"vehicle {missing[0]} of --vehicles is not in the recording")
        tracks = tracks[tracks["source_id"].isin(settings.vehicles)]
    if settings.section_m is not None:
        start, end = settings.section_m
        tracks = tracks[(tracks["x_m"] >= start) & (tracks["x_m"] <= end)]
    return tracks


def split_table(tracks: pd.DataFrame, split_seed: int, test_share: float, validation_share: float,
                hold_out_after_s: float | None = None) -> pa.Table:
    """vehicle_id -> "train" | "validation" | "test": by time (the vehicles entering at or after `hold_out_after_s`
    [s] are the test set, the others shared out by `validation_share`) or by vehicle (a permutation seeded by
    `split_seed` shared out by `test_share` and `validation_share`)."""
    first_s = tracks.groupby("vehicle_id", sort=True)["time_s"].min()
    vehicles = first_s.index.to_numpy()
    split = np.full(len(vehicles), "train", dtype=object)
    rng = np.random.default_rng(split_seed)
    if hold_out_after_s is not None:
        later = first_s.to_numpy() >= hold_out_after_s
        split[later] = "test"
        earlier = np.flatnonzero(~later)
        order = earlier[rng.permutation(len(earlier))]
        split[order[: round(len(earlier) * validation_share)]] = "validation"
    else:
        order = rng.permutation(len(vehicles))
        tests = round(len(vehicles) * test_share)
        validations = round(len(vehicles) * validation_share)
        split[order[:tests]] = "test"
        split[order[tests:tests + validations]] = "validation"
    return pa.table({"vehicle_id": pa.array(vehicles.astype(str)), "split": pa.array(split.astype(str))})


def import_recording(settings: ImportSettings, config: Config, network: NetworkLanes | None) -> ImportSummary:
    """Read, select, check and write the scene folder `settings.out`; `network` is `check_import`'s."""
    recording = read_recording(settings, network)
    period_s = config.env.decision_period_s
    tracks, dropped = kept_tracks(selected(recording, settings), recording.frame_rate_hz, period_s,
                                  settings.files[0], gaps_fail=settings.format == "highd")
    if tracks.empty:
        reasons = sorted(set(dropped.values()))
        raise RecordingDataError(f"no track of {settings.files[0]} is left to keep ({len(dropped)} dropped: "
                                 f"{'; '.join(reasons) or 'none in the section or the vehicles chosen'})")
    split = split_table(tracks, settings.split_seed, settings.test_share, settings.validation_share,
                        settings.hold_out_after_s)
    sources = {str(path.resolve()): file_sha256(path)
               for path in source_files(settings) + ([settings.network] if settings.network else [])}
    recorded = {key: (str(value) if isinstance(value, Path) else value)
                for key, value in dataclasses.asdict(settings).items() if key not in ("out", "overwrite", "files")}
    recorded |= {"decision_period_s": period_s, "vehicles": list(settings.vehicles),
                 "section_m": list(settings.section_m) if settings.section_m else None}
    meta = SceneMeta(format=settings.format, frame_rate_hz=recording.frame_rate_hz,
                     network=str(settings.network.resolve()) if settings.network else "road.net.xml",
                     lanes=recording.lanes, direction=settings.direction if settings.format == "highd" else "",
                     sources=sources, dropped=dropped, settings=recorded)
    write_scene_folder(settings.out, recording, tracks, split, meta, config)
    counts = pd.Series(split.column("split").to_pylist()).value_counts()
    return ImportSummary(len(split), dropped, recording.notes, {name: int(counts.get(name, 0)) for name in SPLITS})


def write_scene_folder(out: Path, recording: Recording, tracks: pd.DataFrame, split: pa.Table, meta: SceneMeta,
                  config: Config) -> None:
    """Write the scene's files together (scene.json last); a folder this call made is removed again on failure."""
    made = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    record = provenance("recording_tracks", config, meta.settings["split_seed"], scene=dataclasses.asdict(meta))
    try:
        with written_together(out) as staged:
            if recording.lane_widths_m:
                build_road(list(recording.lane_widths_m), recording.road_length_m, staged.path(out / "road.net.xml"))
            write_parquet(track_table(tracks), staged.path(out / "tracks.parquet"), record)
            write_parquet(split, staged.path(out / "split.parquet"), {**record, "kind": "recording_split"})
            scene_json = json.dumps(dataclasses.asdict(meta), indent=1, sort_keys=True) + "\n"
            staged.path(out / "scene.json").write_text(scene_json)
    except BaseException:
        if made and not any(out.iterdir()):
            out.rmdir()
        raise
