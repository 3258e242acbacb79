"""Caches: a damaged network or warm-state cache entry is rebuilt, never fatal (`CACHE_DAMAGES`), also between two
episodes and under a command's worker processes."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from reliability import GENERIC, scrambled_middle, truncated
from sumo_rail_cli.main import cli
from test_cli import SMALL, SMALL_CONFIG

from sumo_rail.sim.simulation import EGO_ID

CACHE_FILES = {"network": "networks/*/highway.net.xml", "routes": "networks/*/traffic.rou.xml",
               "warm state": "states/*/state_001.xml"}


def _valid_but_other_state(path: Path) -> None:
    path.write_text('<?xml version="1.0"?>\n<snapshot time="5.00" version="0.1"/>\n')


CACHE_DAMAGES = [(file, damage) for file in CACHE_FILES for damage in ("missing", "empty", "truncated", "garbage")]
CACHE_DAMAGES += [("warm state", "other_snapshot"), ("network", "scrambled_middle")]
CACHE_DAMAGE_FUNCTIONS = {**GENERIC, "other_snapshot": _valid_but_other_state, "scrambled_middle": scrambled_middle}


@pytest.fixture(scope="module")
def cache_template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A cache holding the small scenario's network and warm states."""
    from sumo_rail.sim.simulation import Simulation

    folder = tmp_path_factory.mktemp("cache")
    previous = os.environ["SUMO_RAIL_CACHE"]
    os.environ["SUMO_RAIL_CACHE"] = str(folder)
    try:
        simulation = Simulation(SMALL_CONFIG.scenario, 100.0)
        simulation.reset(0, 1, 0, 300.0)  # builds the train pool's warm states on first use
        simulation.close()
    finally:
        os.environ["SUMO_RAIL_CACHE"] = previous
    return folder


@pytest.mark.parametrize(("file", "damage"), CACHE_DAMAGES)
def test_a_damaged_cache_entry_is_rebuilt(cache_template: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                          file: str, damage: str):
    from sumo_rail.sim.simulation import Simulation

    cache = tmp_path / "cache"
    shutil.copytree(cache_template, cache)
    monkeypatch.setenv("SUMO_RAIL_CACHE", str(cache))
    [path] = cache.glob(CACHE_FILES[file])
    intact = path.read_bytes()
    CACHE_DAMAGE_FUNCTIONS[damage](path)
    simulation = Simulation(SMALL_CONFIG.scenario, 100.0)
    try:
        simulation.reset(1, 7, 0, 300.0)
        simulation.advance_egos(10, [EGO_ID])
    finally:
        simulation.close()
    rebuilt = path.read_bytes()
    assert len(rebuilt) > len(intact) // 2
    if file == "network":  # netconvert writes its date into the file; the rest is the same
        assert rebuilt.split(b"-->", 1)[1] == intact.split(b"-->", 1)[1]
    else:
        assert rebuilt.split(b"<snapshot", 1)[-1] == intact.split(b"<snapshot", 1)[-1]


@pytest.mark.parametrize("file", ["network", "warm state"])
def test_a_cache_entry_damaged_while_running_is_rebuilt_and_the_episode_is_the_same(
        cache_template: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, file: str):
    """SUMO reads the network and the warm state again at every reset: damage between two resets is repaired too."""
    from sumo_rail.sim.simulation import Simulation

    cache = tmp_path / "cache"
    shutil.copytree(cache_template, cache)
    monkeypatch.setenv("SUMO_RAIL_CACHE", str(cache))
    simulation = Simulation(SMALL_CONFIG.scenario, 100.0)
    try:
        episodes = []
        for damage in (None, truncated):
            if damage is not None:
                [path] = cache.glob(CACHE_FILES[file])
                damage(path)
            simulation.reset(1, 7, 2, 300.0)
            simulation.advance_egos(20, [EGO_ID])
            ego, neighbours = simulation.observe()
            episodes.append((ego, neighbours.ids, neighbours.front_xy, neighbours.speed_mps))
    finally:
        simulation.close()
    (ego, ids, xy, speeds), (ego_again, ids_again, xy_again, speeds_again) = episodes
    assert ego == ego_again and ids == ids_again and len(ids) > 3
    assert np.array_equal(xy, xy_again) and np.array_equal(speeds, speeds_again)


def test_a_command_runs_on_a_damaged_cache(tmp_path: Path, cache_template: Path, monkeypatch: pytest.MonkeyPatch):
    """End to end: evaluate's worker processes find truncated warm states, rebuild them, and the results are those
    of the intact cache."""
    cache = tmp_path / "cache"
    shutil.copytree(cache_template, cache)
    monkeypatch.setenv("SUMO_RAIL_CACHE", str(cache))
    evaluate = ["evaluate", *SMALL, "--policy", "keep", "--episodes", "2", "--workers", "2", "--out"]
    before = set(cache.glob("states/*"))
    intact = CliRunner().invoke(cli, [*evaluate, str(tmp_path / "intact.parquet")])
    assert intact.exit_code == 0, intact.output
    [test_pool] = set(cache.glob("states/*")) - before  # evaluate's warm states (the test pool), built by that run
    states = {path: path.read_bytes() for path in sorted(test_pool.glob("state_*.xml"))}
    for path in states:
        truncated(path)
    damaged = CliRunner().invoke(cli, [*evaluate, str(tmp_path / "damaged.parquet")])
    assert damaged.exit_code == 0, damaged.output
    for path, intact_state in states.items():  # rebuilt: the same state again
        assert path.read_bytes().split(b"<snapshot", 1)[-1] == intact_state.split(b"<snapshot", 1)[-1], path.name
    for name in ("{}.parquet", "{}.decisions.parquet"):  # the same episodes and decisions
        pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / name.format("damaged")),
                                      pd.read_parquet(tmp_path / name.format("intact")))


