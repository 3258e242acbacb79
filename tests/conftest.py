"""Shared fixtures: a private cache per test session, a small, fast scenario and a small real workspace."""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Iterator
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


@pytest.fixture(scope="module")
def display(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """A private Xvfb display (1280x800) for a module's sumo-gui tests; its number is chosen by Xvfb itself. Skipped,
    saying why, where no Xvfb binary is installed or it does not start, except in CI (CI=true, whose .ci/run installs
    Xvfb), where both fail."""
    binary = shutil.which("Xvfb")
    if binary is None:
        skip_outside_ci("no Xvfb binary: install the system package xvfb (apt-get install xvfb) to run the GUI tests")
    log = tmp_path_factory.mktemp("xvfb") / "xvfb.log"
    read_end, write_end = os.pipe()
    with log.open("wb") as log_file:
        server = subprocess.Popen([binary, "-displayfd", str(write_end), "-screen", "0", "1280x800x24", "-nolisten",
                                   "tcp"], pass_fds=(write_end,), stdout=subprocess.DEVNULL, stderr=log_file)
    os.close(write_end)
    with os.fdopen(read_end) as pipe:
        number = pipe.readline().strip()
    if not number:
        server.kill()
        server.wait()
        skip_outside_ci(f"{binary} is installed but did not start; its last words: "
                        f"{log.read_text(errors='replace').strip()[-500:]!r}")
    yield f":{number}"
    server.terminate()
    server.wait(timeout=10)


def skip_outside_ci(reason: str) -> None:
    """Skip, saying why; in CI (CI=true), where the display is set up to run these tests, fail instead, so that a
    broken display is not a silent pass."""
    if os.environ.get("CI") == "true":
        pytest.fail(f"{reason} (CI=true: the sumo-gui tests must run here)", pytrace=False)
    pytest.skip(reason)
