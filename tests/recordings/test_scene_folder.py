"""A scene folder read back: a scene on the user's network (FCD) is refused once that network has changed since the
import, by every command that reads the scene, as `train --resume` refuses a changed input."""

from __future__ import annotations

import pytest
from click.testing import CliRunner
from recording_files import fcd_vehicle, lane_y, write_fcd
from sumo_rail_cli.main import cli

from sumo_rail.recordings.road import build_road
from sumo_rail.recordings.scene import read_scene
from sumo_rail.recordings.tracks import RecordingUsageError


@pytest.fixture
def fcd_scene(tmp_path):
    """An FCD scene of three cars on the user's 5-lane road (tmp_path / net.net.xml) and that network."""
    network = tmp_path / "net.net.xml"
    build_road([3.2] * 5, 400.0, network)
    rows = [row for k, lane in enumerate((0, 1, 2)) for row in fcd_vehicle(f"v{k}", range(60), 40.0 + 30 * k,
                                                                           lane_y(5, lane), f"road_{lane}")]
    result = CliRunner().invoke(cli, ["import-recording", "--format", "fcd", str(write_fcd(tmp_path / "fcd.xml", rows)),
                                      "--network", str(network), "--out", str(tmp_path / "scene"),
                                      "--test-share", "0.4", "--validation-share", "0"])
    assert result.exit_code == 0, result.output
    return tmp_path / "scene", network


def test_a_scene_whose_network_changed_since_the_import_is_refused_by_every_command_that_reads_it(fcd_scene,
                                                                                                   tmp_path):
    scene, network = fcd_scene
    assert read_scene(scene).network == network.resolve()
    build_road([3.2] * 5, 500.0, network)  # the same edge and lanes, another length: other positions along it
    said = f"the network {network.resolve()} has changed since the scene {scene} was imported on it (its content " \
           f"hash differs)"
    with pytest.raises(RecordingUsageError, match="has changed since the scene"):
        read_scene(scene)
    for command in (["recorded-demos", str(scene), "--out", str(tmp_path / "demos.parquet")],
                    ["evaluate-scene", str(scene), "--out", str(tmp_path / "metrics.parquet")]):
        result = CliRunner().invoke(cli, command)
        assert result.exit_code == 2 and said in result.output and "Traceback" not in result.output, result.output
        assert not (tmp_path / command[3]).exists()
