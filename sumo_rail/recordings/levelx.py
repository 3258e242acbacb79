"""The file layout of the levelXdata recordings (highD; exiD, inD and rounD keep it): one recording is three CSV
files, XX_tracks.csv (one row per vehicle per frame), XX_tracksMeta.csv (one per vehicle) and XX_recordingMeta.csv
(one row, its frameRate among the columns), each with the dataset's published columns (`LevelXLayout`)."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from sumo_rail.recordings.tracks import (
    RecordingDataError,
    RecordingUsageError,
    check_columns,
    check_numbers,
    plain,
    text_head,
)

SUFFIXES = ("_tracks.csv", "_tracksMeta.csv", "_recordingMeta.csv")


@dataclass(frozen=True)
class LevelXLayout:
    """One dataset's three files: its name (in messages) and the published columns of each file."""

    dataset: str
    tracks_columns: tuple[str, ...]
    tracks_meta_columns: tuple[str, ...]
    recording_meta_columns: tuple[str, ...]

    def recording_files(self, files: list[Path]) -> tuple[Path, Path, Path]:
        """The tracks, tracksMeta and recordingMeta files of the one recording `files` name (any of the three, or
        all); RecordingUsageError when they name several recordings or one of the three is missing."""
        stems = {str(path)[: -len(suffix)] for path in files for suffix in SUFFIXES if str(path).endswith(suffix)}
        strays = [path for path in files if not any(str(path).endswith(suffix) for suffix in SUFFIXES)]
        if strays:
            raise RecordingUsageError(f"{strays[0]} is not a {self.dataset} file (XX_tracks.csv, XX_tracksMeta.csv "
                                      f"or XX_recordingMeta.csv)")
        if len(stems) != 1:
            raise RecordingUsageError(f"the files name {len(stems)} {self.dataset} recordings; import one recording "
                                      f"at a time")
        stem = stems.pop()
        paths = tuple(Path(stem + suffix) for suffix in SUFFIXES)
        for path in paths:
            if not path.is_file():
                raise RecordingUsageError(f"{self.dataset} file {path} does not exist (a recording is its tracks, "
                                          f"tracksMeta and recordingMeta files)")
        return paths[0], paths[1], paths[2]

    def check_headers(self, files: list[Path]) -> None:
        """RecordingUsageError when a file lacks a column of the dataset's published set (before any work)."""
        columns = (self.tracks_columns, self.tracks_meta_columns, self.recording_meta_columns)
        for path, expected in zip(self.recording_files(files), columns, strict=True):
            header = next(csv.reader([text_head(path)[0]]), [])
            check_columns([name.strip() for name in header], expected, path,
                          f"{self.dataset} {path.name.split('_', 1)[1]}")

    @staticmethod
    def frame_rate_hz(recording: pd.DataFrame, path: Path) -> float:
        """The recording's frames per second [Hz] (its recordingMeta `recording`, read from `path`);
        RecordingDataError when it is not a positive number."""
        check_numbers(recording, ("frameRate",), path, "id", "frameRate")
        rate = float(recording["frameRate"].iat[0])
        if not 0 < rate < np.inf:
            raise RecordingDataError(f"{path}: frameRate {plain(rate)} is not a positive number of frames per second")
        return rate
