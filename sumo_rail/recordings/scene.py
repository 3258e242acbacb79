"""The scene: the contract between the recording readers/writers and everything that replays or learns from them,
whole: the track schema, the meta, the folder's files and how they are written, read back and checked.

A scene is one driving direction of a recording on one road: every vehicle's track as rows of `TRACK_COLUMNS`
(one row per vehicle per frame, SI units) and a `SceneMeta`. Positions are in the coordinates of the scene's SUMO
network (`road.net.xml` in the scene folder, or the user's network for FCD), at the centre of the vehicle's front
bumper (SUMO's own convention, so `moveToXY` takes them as they are); `lane` is SUMO's lane index on the vehicle's
edge (0 = the rightmost lane in the driving direction). A scene folder holds `SCENE_FILES`: `tracks.parquet`,
`split.parquet` (vehicle_id -> one of `SPLITS`) and `scene.json` (the `SceneMeta`), and `road.net.xml` when the road
was built from the recording. `write_scene_folder` writes them together (`import-recording`, `record-sumo-drivers`);
`read_scene` reads them back and `check_scene` says whether a configuration can drive and observe on it.
"""

from __future__ import annotations

import dataclasses
import functools
import json
from dataclasses import dataclass, field
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
    read_table,
    write_parquet,
    written_together,
)
from sumo_rail.recordings.road import build_road
from sumo_rail.recordings.scene_observations import SceneRoad, scene_road
from sumo_rail.recordings.tracks import Recording, RecordingDataError, RecordingUsageError
from sumo_rail.runners.tables import provenance

TRACK_SCHEMA = pa.schema([
    ("vehicle_id", pa.string()),        # unique in the scene (a reused id in the source is split: "17", "17#2")
    ("time_s", pa.float64()),           # [s] from the start of the recording
    ("x_m", pa.float64()),              # [m] network x of the front bumper's centre
    ("y_m", pa.float64()),              # [m] network y of the front bumper's centre
    ("heading_deg", pa.float64()),      # [deg] SUMO's angle: 0 = north, clockwise (90 = east)
    ("speed_mps", pa.float64()),        # [m/s] along the heading
    ("acceleration_mps2", pa.float64()),  # [m/s^2] along the heading
    ("edge", pa.string()),              # SUMO edge id of the network the vehicle is on
    ("lane", pa.int16()),               # SUMO lane index on that edge, 0 = rightmost
    ("lane_position_m", pa.float64()),  # [m] position of the front bumper along the lane
    ("length_m", pa.float32()),         # [m] vehicle length
    ("width_m", pa.float32()),          # [m] vehicle width
    ("vehicle_class", pa.string()),     # SUMO vehicle class: "passenger" or "truck" (buses read as truck)
])
TRACK_COLUMNS = tuple(TRACK_SCHEMA.names)
SPLITS = ("train", "validation", "test")
SCENE_FILES = ("tracks.parquet", "split.parquet", "scene.json")
"""The files every scene folder holds (and `road.net.xml` when its road was built from the recording)."""


@dataclass(frozen=True)
class SceneMeta:
    """What a scene is and where it came from (stored as scene.json)."""

    format: str
    """Source format: a name of `formats.FORMATS` ("highd", "ngsim", "fcd"; "sumo": SUMO's drivers, from a run)."""
    frame_rate_hz: float
    """Frames per second of the tracks [Hz] (highD 25, NGSIM 10, FCD 1 / --step-length)."""
    network: str
    """The SUMO network the positions refer to: "road.net.xml" (in the scene folder) or an absolute path."""
    lanes: int
    """Lanes of the modelled road in the scene's driving direction."""
    direction: str = ""
    """The recording's driving direction kept (highD: "upper" / "lower", or "both"; NGSIM and FCD: "")."""
    sources: dict[str, str] = field(default_factory=dict)
    """Each source file's absolute path -> sha256 of its bytes."""
    dropped: dict[str, str] = field(default_factory=dict)
    """Each dropped track's source id -> the one-phrase reason (too short, gap in frames)."""
    settings: dict[str, object] = field(default_factory=dict)
    """The import's settings (section, vehicles, minimum track length ...), for provenance."""
    vehicle_types: dict[str, str] = field(default_factory=dict)
    """Each vehicle's SUMO vType id where the recording names one (FCD's `type`, SUMO's drivers' types)."""
    vtypes: dict[str, dict[str, str]] = field(default_factory=dict)
    """The definitions (vType attributes) of those types that the recording came with: the user's route or
    additional file given to `import-recording` (FCD), or the run's own (SUMO's drivers)."""


def track_table(tracks: pd.DataFrame) -> pa.Table:
    """The kept tracks as a table of `TRACK_SCHEMA`."""
    return pa.Table.from_pandas(tracks[list(TRACK_COLUMNS)], schema=TRACK_SCHEMA, preserve_index=False)


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


def check_scene_output(out: Path, overwrite: bool) -> None:
    """RecordingUsageError unless a scene folder can be written to `out` (without `overwrite`: holding no scene)."""
    try:
        check_output_folder(out)
    except DatasetError as error:
        raise RecordingUsageError(str(error)) from error
    existing = [name for name in (*SCENE_FILES, "road.net.xml") if (out / name).exists()]
    if existing and not overwrite:
        raise RecordingUsageError(f"{out} already holds a scene ({existing[0]}); pass --overwrite to replace it")


def write_scene_folder(out: Path, recording: Recording, tracks: pd.DataFrame, split: pa.Table, meta: SceneMeta,
                       config: Config) -> None:
    """Write the scene's files together (scene.json last); a folder this call made is removed again on failure."""
    made = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    seed = meta.settings["split_seed"]
    assert isinstance(seed, int)  # the split's seed, as every scene's settings hold it
    record = provenance("recording_tracks", config, seed, scene=dataclasses.asdict(meta))
    try:
        with written_together(out) as staged:
            if recording.lane_widths_m:
                build_road(list(recording.lane_widths_m), recording.road_length_m, staged.path(out / "road.net.xml"),
                           list(recording.opposite_lane_widths_m), recording.median_m, recording.ramp_lane_m)
            write_parquet(track_table(tracks), staged.path(out / "tracks.parquet"), record)
            write_parquet(split, staged.path(out / "split.parquet"), {**record, "kind": "recording_split"})
            scene_json = json.dumps(dataclasses.asdict(meta), indent=1, sort_keys=True) + "\n"
            staged.path(out / "scene.json").write_text(scene_json)
    except BaseException:
        if made and not any(out.iterdir()):
            out.rmdir()
        raise


@dataclass(frozen=True)
class Scene:
    """A scene folder read back: its meta, tracks (`TRACK_COLUMNS`), split and network file."""

    folder: Path
    meta: SceneMeta
    tracks: pd.DataFrame
    split: pd.DataFrame
    network: Path

    @functools.cached_property
    def _rows_of(self) -> dict[str, np.ndarray]:
        """Each vehicle's row positions in `tracks` (found once: a mask over a highD-sized table takes milliseconds
        per vehicle)."""
        return {str(vehicle): rows for vehicle, rows in self.tracks.groupby("vehicle_id", sort=False).indices.items()}

    @functools.cached_property
    def road(self) -> SceneRoad:
        """The scene's road on its network (read once)."""
        return scene_road(self.network)

    def track(self, vehicle: str) -> pd.DataFrame:
        """One vehicle's rows in time order; DatasetError when the scene has no such vehicle."""
        rows = self._rows_of.get(vehicle)
        if rows is None:
            raise DatasetError(f"scene {self.folder} has no vehicle {vehicle!r}")
        contiguous = rows[-1] - rows[0] + 1 == len(rows)  # as the scene writers write them: a slice, no copy
        return self.tracks.iloc[slice(rows[0], rows[-1] + 1) if contiguous else rows].sort_values("time_s")

    def track_values(self, vehicle: str, names: tuple[str, ...]) -> dict[str, np.ndarray]:
        """Columns `names` of one vehicle's rows in time order, as `track` orders them (its sort, a quicksort of the
        times), without building a DataFrame (milliseconds less a call: a seat's every reset reads its lead-in);
        DatasetError when the scene has no such vehicle."""
        rows = self._rows_of.get(vehicle)
        if rows is None:
            raise DatasetError(f"scene {self.folder} has no vehicle {vehicle!r}")
        rows = rows[self._column("time_s")[rows].argsort(kind="quicksort")]
        return {name: self._column(name)[rows] for name in names}

    @functools.cached_property
    def _columns(self) -> dict[str, np.ndarray]:
        """The columns `track_values` has read, as arrays (`_column`)."""
        return {}

    def _column(self, name: str) -> np.ndarray:
        """Column `name` of `tracks` as an array, converted once."""
        column = self._columns.get(name)
        if column is None:
            column = self._columns[name] = self.tracks[name].to_numpy()
        return column


_JSON_KINDS: dict[str, type | tuple[type, ...]] = {"str": str, "float": (int, float), "int": int}
"""The JSON value type of a SceneMeta field by its annotation (the others: an object)."""


def read_scene(folder: Path) -> Scene:
    """The scene folder `folder`; RecordingUsageError naming a missing file, or the network (the user's, for FCD)
    whose content has changed since the scene was imported on it (scene.json holds its sha256); RecordingDataError
    naming a file that is there but cannot be read (damaged, truncated, not the scene's format)."""
    try:
        for name in SCENE_FILES:
            check_file(folder / name, "scene file")
    except DatasetError as error:
        raise RecordingUsageError(f"{folder} is not a readable scene folder ({error})") from error
    try:
        meta = SceneMeta(**json.loads((folder / "scene.json").read_text()))
        for entry in dataclasses.fields(SceneMeta):  # the types its readers rely on (a mapping's .get, a number)
            kind = _JSON_KINDS.get(str(entry.type), dict)
            if not isinstance(value := getattr(meta, entry.name), kind) or isinstance(value, bool):
                raise TypeError(f"{entry.name} is {json.dumps(value)}, not a {str(entry.type).split('[')[0]}")
        network = Path(meta.network) if Path(meta.network).is_absolute() else folder / meta.network
    except (json.JSONDecodeError, TypeError, KeyError, UnicodeDecodeError) as error:
        raise RecordingDataError(f"the scene file {folder / 'scene.json'} is damaged ({error})") from error
    try:
        check_file(network, "scene network")
    except DatasetError as error:
        raise RecordingUsageError(f"{folder} is not a readable scene folder ({error})") from error
    try:
        tracks = read_table(folder / "tracks.parquet", columns=list(TRACK_COLUMNS)).to_pandas()
        split = read_table(folder / "split.parquet", columns=["vehicle_id", "split"]).to_pandas()
    except DatasetError as error:
        raise RecordingDataError(f"{folder} is not a readable scene folder ({error})") from error
    recorded = meta.sources.get(meta.network)
    if recorded is not None and recorded != file_sha256(network):
        raise RecordingUsageError(f"the network {network} has changed since the scene {folder} was imported on it "
                                  f"(its content hash differs); use the scene with the network it was imported on, "
                                  f"or import the recording again")
    return Scene(folder, meta, tracks, split, network)


def check_scene(scene: Scene, config: Config, split: str) -> SceneRoad:
    """The scene's road; RecordingUsageError when the scene cannot give this configuration's observation (another
    lane count, a network that cannot be read), its road's speed limit is not this configuration's
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
    check_tracks(scene, road)
    return road


def check_tracks(scene: Scene, road: SceneRoad) -> None:
    """RecordingDataError naming the first vehicle of the scene's split in none of `SPLITS` or with no track, or of its
    tracks on a lane its network does not have or with a number that is not finite: a damaged split.parquet or
    tracks.parquet (hand-edited, another scene's), which import-recording never writes and the readers would fail on
    mid-way."""
    unknown = scene.split[~scene.split["split"].isin(SPLITS)]
    if len(unknown):
        row = unknown.iloc[0]
        raise RecordingDataError(f"{scene.folder / 'split.parquet'}: vehicle {row['vehicle_id']} is in split "
                                 f"{row['split']!r}, none of {', '.join(SPLITS)}: the scene is damaged")
    tracks, where = scene.tracks, scene.folder / "tracks.parquet"
    trackless = scene.split[~scene.split["vehicle_id"].isin(tracks["vehicle_id"])]
    if len(trackless):
        raise RecordingDataError(f"{scene.folder / 'split.parquet'}: vehicle {trackless['vehicle_id'].iloc[0]} has no "
                                 f"track in {where}: the scene is damaged")
    numbers = [name for name in TRACK_COLUMNS if pa.types.is_floating(TRACK_SCHEMA.field(name).type)]
    broken = ~np.isfinite(tracks[numbers].to_numpy(dtype=float)).all(axis=1)
    if broken.any():
        row = tracks[broken].iloc[0]
        column = next(name for name in numbers if not np.isfinite(row[name]))
        raise RecordingDataError(f"{where}: {column} of vehicle {row['vehicle_id']} at {row['time_s']:g} s is "
                                 f"{row[column]}, not a number: the scene is damaged")
    pairs = tracks[["edge", "lane"]].drop_duplicates()
    known = set(road.net.lane.getIDList())
    off = [f"{edge}_{lane}" not in known for edge, lane in pairs.itertuples(index=False)]
    if any(off):
        edge, lane = pairs[off].iloc[0]
        row = tracks[(tracks["edge"] == edge) & (tracks["lane"] == lane)].iloc[0]
        raise RecordingDataError(f"{where}: vehicle {row['vehicle_id']} at {row['time_s']:g} s is on lane {lane} of "
                                 f"edge {edge}, which the scene's network {scene.network} does not have: the scene "
                                 f"is damaged")


SPEED_TOLERANCE_MPS = 0.005
"""Speeds this close are one (a network file writes speeds to 0.01 m/s)."""


def check_speed_limit(road_limit_mps: float, config: Config, what: str) -> None:
    """RecordingUsageError unless `config` drives at the speed limit `road_limit_mps` [m/s] of the road `what` (a
    scene's, named in the sentence): scenario.speed_limit_mps is that limit (the generated roads' and the driving
    score's), and env.v_max_mps (the highest set-point, the observation's speed scale) is not below it, so that the
    set-points and the ego can reach the recorded drivers' speeds."""
    limit, top, road = config.scenario.speed_limit_mps, config.env.v_max_mps, road_limit_mps
    wrong: dict[str, str] = {}  # the fix -> what is wrong
    if abs(limit - road) > SPEED_TOLERANCE_MPS:
        wrong[f"scenario.speed_limit_mps={road:g}"] = f"scenario.speed_limit_mps={limit:g} (not the road's limit)"
    if top < road - SPEED_TOLERANCE_MPS:
        wrong[f"env.v_max_mps={road:g}"] = f"env.v_max_mps={top:g} (the highest set-point, below the limit)"
    if wrong:
        raise RecordingUsageError(f"{what} has a speed limit of {road:g} m/s and this configuration has "
                                  f"{' and '.join(wrong.values())}; pass --set {' --set '.join(wrong)}")


def scene_sources(scene: Scene) -> dict[str, str]:
    """The scene's own files (and its network) -> sha256 of their bytes."""
    paths = [scene.folder / name for name in SCENE_FILES] + [scene.network]
    return {str(path.resolve()): file_sha256(path) for path in paths}
