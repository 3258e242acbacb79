"""`sumo-rail import-recording`: a recording of any format of `formats.FORMATS` read from files (highD, NGSIM, FCD)
-> a scene folder (`scene` holds the contract: its schema, meta and files).

The format is looked up by name; what it takes (a network, a direction, a site) and how it is checked and read are
its `RecordingFormat`'s. Everything a user can get wrong in the command (files, options, columns, the network: for FCD
a SUMO network with an edge, as `recorded-demos` and `evaluate-scene` take) is checked by `check_import` before any
work (`RecordingUsageError`); what is wrong in the data is found while reading (`RecordingDataError`). The folder's
files are written together: on any error none of them is. scene.json pins every file read by its sha256.
"""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ElementTree
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from sumo_rail.config import Config, ConfigError
from sumo_rail.datasets import DatasetError, check_file, file_sha256
from sumo_rail.recordings.formats import FORMATS, ReadOptions, RecordingFormat, importable, taking
from sumo_rail.recordings.road import read_lanes
from sumo_rail.recordings.scene import SPLITS, SceneMeta, check_scene_output, split_table, write_scene_folder
from sumo_rail.recordings.scene_observations import scene_road
from sumo_rail.recordings.tracks import MAX_LENGTH_M, Recording, RecordingDataError, RecordingUsageError, kept_tracks
from sumo_rail.sim.vehicle_types import check_vtypes, read_vtypes


@dataclass(frozen=True)
class ImportSettings:
    """What to import and how (the options of `sumo-rail import-recording`)."""

    format: str
    files: tuple[Path, ...]
    out: Path
    direction: str = "lower"
    """highD: the driving direction kept ("upper" or "lower"), or "both" (each on its own carriageway's edge)."""
    site: str = "us-101"
    """NGSIM: the site ("us-101" or "i-80"), which fixes the main lanes."""
    period: int | None = None
    """NGSIM: the recording period to read (1: the earliest) of files that hold several; None: the only one."""
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
    vtypes: Path | None = None
    """FCD: a route or additional file defining the vTypes the recording's `type` names (the reactive replay drives
    each vehicle by its own, `scene_drivers`)."""


@dataclass(frozen=True)
class ImportSummary:
    """What an import kept and dropped."""

    kept: int
    dropped: dict[str, str]
    notes: list[str]
    split_counts: dict[str, int]


def check_import(settings: ImportSettings) -> ReadOptions:
    """RecordingUsageError for anything wrong before work starts; returns what the format's reader is told."""
    form = FORMATS.get(settings.format)
    if form is None or not form.importable:
        raise RecordingUsageError(f"unknown format {settings.format!r}; known: "
                                  f"{', '.join(known.name for known in importable())}")
    if not settings.files:
        raise RecordingUsageError("no recording files given")
    if (settings.network is not None) != form.network:
        raise RecordingUsageError(f"--network is needed for --format {' and '.join(f.name for f in taking('network'))} "
                                  f"and only for it")
    if settings.vtypes is not None and not form.network:
        raise RecordingUsageError(f"--vtypes applies to --format {' or '.join(f.name for f in taking('network'))} "
                                  f"only (the formats that name SUMO vTypes)")
    if settings.period is not None and "site" not in form.choices:
        raise RecordingUsageError(f"--period applies to --format {' or '.join(f.name for f in taking('site'))} only "
                                  f"(files that hold several recording periods)")
    options = ReadOptions(direction=settings.direction, site=settings.site, period=settings.period,
                          network=settings.network)
    for option, values in form.choices.items():
        if getattr(options, option) not in values:
            raise RecordingUsageError(f"--{option} {getattr(options, option)!r} is not one of {form.name}'s: "
                                      f"{', '.join(values)}")
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
    form.check_headers(settings.files)
    if settings.network is not None:
        try:
            read_lanes(settings.network)
            scene_road(settings.network)  # what recorded-demos and evaluate-scene take
        except DatasetError as error:
            raise RecordingUsageError(str(error)) from error
    if settings.vtypes is not None and settings.network is not None:
        options = dataclasses.replace(options, vtypes=vtype_definitions(settings.vtypes, settings.network))
    return options


def vtype_definitions(path: Path, network: Path) -> dict[str, dict[str, str]]:
    """The vTypes a SUMO route or additional file `path` defines (`sim.vehicle_types.read_vtypes`: id -> definition),
    each as SUMO takes it on `network`; RecordingUsageError naming the file (and the type and what is wrong in it) when
    it is not readable XML, defines none or one SUMO refuses."""
    try:
        check_file(path, "vType file")
        root = ElementTree.parse(path).getroot()
    except (DatasetError, ElementTree.ParseError) as error:
        raise RecordingUsageError(f"--vtypes {path} is not a readable route or additional file ({error})") from error
    try:
        found = read_vtypes(root)
        if not found:
            raise RecordingUsageError(f"--vtypes {path} defines no vType")
        check_vtypes(network, found)
    except ConfigError as error:
        raise RecordingUsageError(f"--vtypes {path}: {error}") from error
    for type_id, definition in found.items():
        length_m = float(definition.get("length", 0.0) or 0.0)
        if length_m > MAX_LENGTH_M:
            raise RecordingUsageError(f"--vtypes {path}: vType {type_id} has length {length_m:g} m, longer than "
                                      f"{MAX_LENGTH_M:g} m (the longest vehicle a recording may hold)")
    return found


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


def recorded_types(tracks: pd.DataFrame, defined: Mapping[str, Mapping[str, str]]) -> dict[str, dict]:
    """`SceneMeta`'s vehicle_types (each kept vehicle's vType, where the reader read one: a "type" column) and vtypes
    (the definitions of those types among `defined`, the --vtypes file's)."""
    if "type" not in tracks:
        return {}
    first = tracks.drop_duplicates("vehicle_id")
    named = dict(zip(first["vehicle_id"].astype(str), first["type"].astype(str), strict=True))
    kept = sorted(set(named.values()) & set(defined))
    return {"vehicle_types": named, "vtypes": {type_id: dict(defined[type_id]) for type_id in kept}}


def foreign_settings(form: RecordingFormat) -> tuple[str, ...]:
    """The `ImportSettings` fields that only other formats read (scene.json records the rest)."""
    return ((() if "direction" in form.choices else ("direction",))
            + (() if "site" in form.choices else ("site", "period")) + (() if form.network else ("network", "vtypes")))


def import_recording(settings: ImportSettings, config: Config, options: ReadOptions) -> ImportSummary:
    """Read, select, check and write the scene folder `settings.out`; `options` are `check_import`'s."""
    form = FORMATS[settings.format]
    recording = form.read(settings.files, options)
    period_s = config.env.decision_period_s
    tracks, dropped = kept_tracks(selected(recording, settings), recording.frame_rate_hz, period_s,
                                  settings.files[0], gaps_fail=form.contiguous)
    if tracks.empty:
        reasons = sorted(set(dropped.values()))
        raise RecordingDataError(f"no track of {settings.files[0]} is left to keep ({len(dropped)} dropped: "
                                 f"{'; '.join(reasons) or 'none in the section or the vehicles chosen'})")
    split = split_table(tracks, settings.split_seed, settings.test_share, settings.validation_share,
                        settings.hold_out_after_s)
    sources = {str(path.resolve()): file_sha256(path) for path in [
        *recording.sources, *(path for path in (settings.network, settings.vtypes) if path is not None)]}
    recorded = {key: (str(value) if isinstance(value, Path) else value)
                for key, value in dataclasses.asdict(settings).items()
                if key not in ("out", "overwrite", "files", *foreign_settings(form))}
    recorded |= {"decision_period_s": period_s, "vehicles": list(settings.vehicles),
                 "section_m": list(settings.section_m) if settings.section_m else None}
    meta = SceneMeta(format=settings.format, frame_rate_hz=recording.frame_rate_hz,
                     network=str(settings.network.resolve()) if settings.network else "road.net.xml",
                     lanes=recording.lanes, direction=settings.direction if "direction" in form.choices else "",
                     sources=sources, dropped=dropped, settings=recorded, **recorded_types(tracks, options.vtypes))
    write_scene_folder(settings.out, recording, tracks, split, meta, config)
    counts = pd.Series(split.column("split").to_pylist()).value_counts()
    return ImportSummary(len(split), dropped, recording.notes, {name: int(counts.get(name, 0)) for name in SPLITS})
