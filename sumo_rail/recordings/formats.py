"""The recording formats a scene is made from, by name: the one registry `import-recording`, `record-sumo-drivers`
and the readers of scenes look a format up in (`FORMATS`).

A format is a `RecordingFormat`: its name, the files it takes, the options its reader reads (a driving direction, a
site; the user's network or a road of its own), whether its tracks are contiguous by definition, how its speeds are
read, and its reader: a module of `FormatReader`'s two functions, `check_headers(files)` (before any work) and
`read(files, options)` (into a `tracks.Recording` of the one track schema, `scene.TRACK_COLUMNS`). The reader is
imported on first use, so the registry itself is light: the command line lists the formats without loading pandas.

A new format is one `RecordingFormat` added to `FORMATS` and its reader module. The levelXdata recordings (exiD, inD,
rounD) come in highD's layout (XX_tracks.csv, XX_tracksMeta.csv, XX_recordingMeta.csv with the frame rate):
their readers take `levelx.LevelXLayout` with their own column sets, as `highd` does.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from sumo_rail.recordings.tracks import Recording


@dataclass(frozen=True)
class ReadOptions:
    """What a reader is told besides its files; each format reads the options its `RecordingFormat` names."""

    direction: str = "lower"
    """highD: the driving direction kept ("upper" or "lower"), or "both" (each on its own carriageway's edge)."""
    site: str = "us-101"
    """NGSIM: the site ("us-101" or "i-80"), which fixes the main lanes."""
    period: int | None = None
    """NGSIM: the recording period to read (1: the earliest) of files that hold several; None: the only one."""
    network: Path | None = None
    """FCD: the SUMO network the positions refer to."""
    vtypes: Mapping[str, Mapping[str, str]] = field(default_factory=dict)
    """FCD: the vTypes the user's --vtypes file defines (id -> attributes): the sizes and classes of their vehicles."""


class FormatReader(Protocol):
    """What a format's reader module provides."""

    def check_headers(self, files: list[Path]) -> None:
        """RecordingUsageError when `files` are not of the format (a missing column, another root element, a
        companion file missing), before any work."""

    def read(self, files: list[Path], options: ReadOptions) -> Recording:
        """The tracks of `files` in the one track schema, and what the scene needs to know (its road, its notes, the
        files read); RecordingDataError for broken data."""


@dataclass(frozen=True)
class RecordingFormat:
    """One format of recorded driving and what importing it takes."""

    name: str
    """The word `--format` and scene.json's `format` use."""
    files: str
    """The files it takes, in words (`import-recording --format`'s help)."""
    reader: str = ""
    """The module that reads it (a `FormatReader`); empty for a format no file is imported from (SUMO's own drivers,
    whose scenes `record-sumo-drivers` writes from a simulation)."""
    choices: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    """The options of `ReadOptions` it reads, each with the values it takes: {"direction": ("upper", "lower")}."""
    network: bool = False
    """Its positions lie on the user's network (`ReadOptions.network`); otherwise the reader gives the road to build."""
    contiguous: bool = False
    """Its tracks have no gaps by definition: a gap is broken data, not a track to drop."""
    speed_smoothing_s: float = 0.0
    """The centred moving average its speeds need before the acceleration interface reads them [s] (speeds derived
    from positions in coarse units); 0 where they are measured or exact."""

    @property
    def importable(self) -> bool:
        """Whether `import-recording` reads it from files."""
        return bool(self.reader)

    def load(self) -> FormatReader:
        """The reader module (imported on first use)."""
        if not self.reader:
            raise ValueError(f"format {self.name} is not read from files")
        return importlib.import_module(self.reader)

    def check_headers(self, files: Sequence[Path]) -> None:
        """The reader's check of `files` before any work."""
        self.load().check_headers(list(files))

    def read(self, files: Sequence[Path], options: ReadOptions) -> Recording:
        """`files` read by the format's reader."""
        return self.load().read(list(files), options)


HIGHD = RecordingFormat("highd", "XX_tracks.csv (its tracksMeta and recordingMeta beside it)",
                        "sumo_rail.recordings.highd", {"direction": ("upper", "lower", "both")},
                        contiguous=True)
NGSIM = RecordingFormat("ngsim", "US-101 / I-80 trajectory CSV or text files (gzip-compressed too)",
                        "sumo_rail.recordings.ngsim", {"site": ("us-101", "i-80")}, speed_smoothing_s=1.0)
FCD = RecordingFormat("fcd", "SUMO --fcd-output XML (.xml or .xml.gz)", "sumo_rail.recordings.fcd", network=True)
SUMO_DRIVERS = RecordingFormat("sumo", "none: a simulation of SUMO's own drivers (record-sumo-drivers)")
FORMATS: dict[str, RecordingFormat] = {form.name: form for form in (HIGHD, NGSIM, FCD, SUMO_DRIVERS)}
"""Every format a scene can come from, by name."""


def importable() -> list[RecordingFormat]:
    """The formats `import-recording` reads, in registry order."""
    return [form for form in FORMATS.values() if form.importable]


def taking(option: str) -> list[RecordingFormat]:
    """The formats that read `option` ("network", or one of `ReadOptions`' choices: "direction", "site")."""
    return [form for form in FORMATS.values() if (form.network if option == "network" else option in form.choices)]


def values(option: str) -> tuple[str, ...]:
    """The values of the choice `option` ("direction", "site") over every format that reads it, in registry order."""
    return tuple(dict.fromkeys(value for form in taking(option) for value in form.choices[option]))
