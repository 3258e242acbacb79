"""Shared fixtures: a private cache per test session, a small, fast scenario and a small real workspace."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from sumo_rail.config import Config


@pytest.fixture(scope="session", autouse=True)
def private_cache(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Build networks and warm states in a fresh cache, so tests never depend on an earlier run."""
    os.environ["SUMO_RAIL_CACHE"] = str(tmp_path_factory.mktemp("sumo-rail-cache"))


@pytest.fixture
def small_config() -> Config:
    """A shorter road and warm-up: episodes of ~60 decisions."""
    return Config.from_dict({
        "scenario": {"length_m": 1500.0, "warmup_s": 120.0, "snapshots": 3, "snapshot_interval_s": 10.0},
        "env": {"ego_start_min_m": 300.0, "ego_start_max_m": 500.0},
    })


@pytest.fixture(scope="module")
def small_config_module() -> Config:
    """`small_config` for a module's fixtures."""
    return Config.from_dict({"scenario": {"length_m": 1500.0, "warmup_s": 120.0, "snapshots": 3,
                                          "snapshot_interval_s": 10.0},
                             "env": {"ego_start_min_m": 300.0, "ego_start_max_m": 500.0}})


@pytest.fixture(scope="module")
def demos_path(tmp_path_factory: pytest.TempPathFactory, small_config_module: Config) -> Path:
    """The normal expert's demonstrations of two episodes on the small road."""
    from sumo_rail.datasets import write_parquet
    from sumo_rail.runners.backends import SerialBackend
    from sumo_rail.runners.rollout import EpisodeTask, ExpertDriver
    from sumo_rail.runners.tables import DEMONSTRATIONS, demonstrations_table, provenance

    path = tmp_path_factory.mktemp("demos") / "demos.parquet"
    seeds = [0, 3]
    with SerialBackend() as backend:
        results = backend.run([EpisodeTask(small_config_module, ExpertDriver("normal"), s, record=True)
                               for s in seeds])
    write_parquet(demonstrations_table(results, seeds, 56), path, provenance(DEMONSTRATIONS, small_config_module, 0))
    return path


@pytest.fixture(scope="session")
def workspace_template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small real workspace, made once (`reliability.make_workspace`)."""
    from reliability import make_workspace

    folder = tmp_path_factory.mktemp("workspace")
    make_workspace(folder)
    return folder


@pytest.fixture
def workspace(workspace_template: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A copy of the small workspace, made the working directory (the run's settings hold relative paths)."""
    folder = tmp_path / "workspace"
    shutil.copytree(workspace_template, folder)
    monkeypatch.chdir(folder)
    return folder
