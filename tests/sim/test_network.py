import shutil
from pathlib import Path

import pytest
import sumolib

from sumo_rail.config import ConfigError, ScenarioConfig
from sumo_rail.sim import network


def test_default_highway_has_five_lanes_and_its_length():
    built = network.build(ScenarioConfig())
    net = sumolib.net.readNet(str(built.net_file))
    edge = net.getEdge(network.EDGE_ID)
    assert edge.getLaneNumber() == 5
    assert edge.getLength() == pytest.approx(3000.0, abs=0.5)
    assert edge.getSpeed() == pytest.approx(33.33, abs=0.01)


def test_settings_shape_the_network():
    built = network.build(ScenarioConfig(length_m=2000.0, lanes=3, speed_limit_mps=25.0))
    edge = sumolib.net.readNet(str(built.net_file)).getEdge(network.EDGE_ID)
    assert (edge.getLaneNumber(), round(edge.getLength()), round(edge.getSpeed())) == (3, 2000, 25)


def test_cached_build_is_reused_and_rebuilt_when_sources_change(tmp_path: Path):
    first = network.build(ScenarioConfig())
    stamp = first.net_file.stat().st_mtime_ns
    assert network.build(ScenarioConfig()).net_file == first.net_file
    assert first.net_file.stat().st_mtime_ns == stamp
    sources = tmp_path / "sources"
    shutil.copytree(network.sources_dir(), sources)
    routes = sources / "traffic.rou.xml"
    routes.write_text(routes.read_text().replace('sigma="0.5"', 'sigma="0.4"', 1))
    assert network.build(ScenarioConfig(), source_dir=sources).directory != first.directory


def test_flow_sets_poisson_arrival_rate():
    built = network.build(ScenarioConfig(flow_veh_per_h=1800.0))
    flow = sumolib.xml.parse_fast(str(built.routes_file), "flow", ["id", "period"])
    assert [f.period for f in flow] == ["exp(0.5)"]


@pytest.mark.parametrize("content", ["<nodes><node id='start'", None])
def test_unreadable_sources_are_config_errors(tmp_path: Path, content):
    sources = tmp_path / "sources"
    shutil.copytree(network.sources_dir(), sources)
    target = sources / "highway.nod.xml"
    if content is None:
        target.unlink()
    else:
        target.write_text(content)
    with pytest.raises(ConfigError, match=r"highway\.nod\.xml"):
        network.build(ScenarioConfig(), source_dir=sources)
