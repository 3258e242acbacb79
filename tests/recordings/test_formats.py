"""The format registry (`sumo_rail.recordings.formats`): importing looks a format up by name, a new format is one
registration, every reader has the one signature, and the registry is light enough for the command line."""

from __future__ import annotations

import dataclasses
import inspect
import json
import subprocess
import sys

import pytest
from click.testing import CliRunner
from recording_files import highd_vehicle, write_highd
from sumo_rail_cli.main import cli

from sumo_rail.config import Config
from sumo_rail.recordings import highd
from sumo_rail.recordings.formats import FORMATS, HIGHD, importable
from sumo_rail.recordings.importing import ImportSettings, check_import, import_recording
from sumo_rail.recordings.levelx import LevelXLayout
from sumo_rail.recordings.tracks import RecordingDataError, RecordingUsageError


def lower_direction(folder, gap: bool = False):
    """Six vehicles of the lower direction, 2 s each; with `gap`, vehicle 3 misses one frame."""
    rows = [row for vehicle in range(1, 7) for row in highd_vehicle(vehicle, range(1, 51), 20.0 * vehicle, 5, False)
            if not (gap and vehicle == 3 and row["frame"] == 20)]
    return write_highd(folder, rows)


def test_a_format_registered_once_is_imported_by_lookup(tmp_path, monkeypatch):
    """A levelXdata format of highD's layout is one entry: its name, options and contiguity come from the registry."""
    monkeypatch.setitem(FORMATS, "levelx", dataclasses.replace(HIGHD, name="levelx"))
    recording = lower_direction(tmp_path)
    settings = ImportSettings("levelx", (recording,), tmp_path / "scene", test_share=0.0, validation_share=0.0)
    summary = import_recording(settings, Config(), check_import(settings))
    scene = json.loads((tmp_path / "scene" / "scene.json").read_text())
    assert summary.kept == 6 and scene["format"] == "levelx" and scene["direction"] == "lower"
    assert len(scene["sources"]) == 3  # the reader's companion files, as it reported them
    (tmp_path / "gap").mkdir()
    broken = ImportSettings("levelx", (lower_direction(tmp_path / "gap", gap=True),), tmp_path / "other")
    with pytest.raises(RecordingDataError, match="vehicle 3 has a gap in its frames"):
        import_recording(broken, Config(), check_import(broken))


def test_which_format_takes_an_option_is_the_registrys(tmp_path, monkeypatch):
    monkeypatch.setitem(FORMATS, "levelx", dataclasses.replace(HIGHD, name="levelx"))
    result = CliRunner().invoke(cli, ["import-recording", "--format", "ngsim", str(lower_direction(tmp_path)),
                                      "--direction", "upper", "--out", str(tmp_path / "scene")])
    assert result.exit_code == 2 and "--direction applies to --format highd or levelx only" in result.output


def test_a_value_a_format_does_not_take_and_a_format_read_from_no_file_are_refused(tmp_path):
    recording = lower_direction(tmp_path)
    with pytest.raises(RecordingUsageError, match="--direction 'sideways' is not one of highd's: upper, lower"):
        check_import(ImportSettings("highd", (recording,), tmp_path / "scene", direction="sideways"))
    with pytest.raises(RecordingUsageError, match="unknown format 'sumo'; known: highd, ngsim, fcd"):
        check_import(ImportSettings("sumo", (recording,), tmp_path / "scene"))
    assert not FORMATS["sumo"].importable and not (tmp_path / "scene").exists()


@pytest.mark.parametrize("name", [form.name for form in importable()])
def test_every_reader_has_the_one_signature(name):
    reader = FORMATS[name].load()
    assert list(inspect.signature(reader.read).parameters) == ["files", "options"]
    assert list(inspect.signature(reader.check_headers).parameters) == ["files"]


def test_the_registry_lists_the_formats_without_loading_a_reader():
    code = ("import sys; from sumo_rail.recordings.formats import FORMATS; "
            "print(sorted(FORMATS), 'pandas' in sys.modules, 'sumo_rail.recordings.highd' in sys.modules)")
    found = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert found.strip() == "['fcd', 'highd', 'ngsim', 'sumo'] False False"
    assert FORMATS["highd"].load() is highd


def test_a_levelx_layout_names_its_dataset_and_columns(tmp_path):
    recording = lower_direction(tmp_path)
    exid = LevelXLayout("exiD", ("recordingId", *highd.TRACKS_COLUMNS), highd.TRACKS_META_COLUMNS,
                        highd.RECORDING_META_COLUMNS)
    highd.check_headers([recording])
    with pytest.raises(RecordingUsageError, match=r"is not a exiD tracks\.csv file: it lacks the column 'recordingId'"):
        exid.check_headers([recording])
    with pytest.raises(RecordingUsageError, match="is not a exiD file"):
        exid.check_headers([tmp_path / "other.csv"])
