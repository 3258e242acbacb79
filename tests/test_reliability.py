"""Reliability: nothing a disk, a crash or a person does to the files sumo-rail reads back gets a traceback.

Damaged inputs. `DAMAGES` is one table of (file, damage) pairs; `READERS` says which command reads which file.
Each case copies a small real workspace made once per module (demonstrations, a one-iteration RAIL run folder, a
metrics file), damages one file, runs the command through click and checks that it answers with one sentence
naming the file (exit 1, or 2 for a usage error), prints no traceback and leaves every file of the workspace as it
was, byte for byte. A new file joins with a `FILES` entry (its damages follow from its format); a new command
(dagger, the exports) joins with rows of `READERS`.

Caches: a damaged network or warm-state cache entry is rebuilt (`CACHE_DAMAGES`), also between two episodes.
Workers: a killed or failing GAIL environment process is one sentence. Full disk: a save that fails (ENOSPC from
each writer in turn) keeps the previous complete iteration, every file of it, and says so.
(The process pool's and Ray's recovery from killed workers is tested in tests/runners/ and
tests/learning/rail/test_trainer.py.)
"""

from __future__ import annotations

import errno
import fractions
import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import torch
from click.testing import CliRunner, Result
from sumo_rail_cli.main import cli
from test_cli import SMALL, SMALL_CONFIG

from sumo_rail.datasets import METADATA_KEY

# ---------------------------------------------------------------------------------------------------------------------
# The files the project reads back, where they are in the workspace, and their format.


@dataclass(frozen=True)
class File:
    path: str
    """In the workspace."""
    format: str
    """json, torch, npz or parquet: which damages apply."""


FILES = {
    "run.json": File("run/run.json", "json"),
    "checkpoint.pt": File("run/checkpoint.pt", "torch"),
    "policy_bc.npz": File("run/policy_bc.npz", "npz"),
    "policy_latest.npz": File("run/policy_latest.npz", "npz"),
    "log.parquet": File("run/log.parquet", "parquet"),
    "demonstrations": File("demos.parquet", "parquet"),
    "metrics": File("metrics.parquet", "parquet"),
}
# discriminator.pt is written for users but read back by no command; it joins here when one reads it.

# ---------------------------------------------------------------------------------------------------------------------
# Damages: what a disk, a crash or a person can do to a file. Each takes the file's path and changes it in place.


def _missing(path: Path) -> None:
    path.unlink()


def _empty(path: Path) -> None:
    path.write_bytes(b"")


def _truncated(path: Path) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def _garbage(path: Path) -> None:
    path.write_bytes(np.random.default_rng(0).bytes(path.stat().st_size))


def _scrambled_middle(path: Path) -> None:
    """64 bytes in the middle overwritten: a bad sector; the file keeps its size, head and tail."""
    data = bytearray(path.read_bytes())
    middle = len(data) // 2
    data[middle:middle + 64] = np.random.default_rng(1).bytes(64)
    path.write_bytes(bytes(data))


GENERIC = {"missing": _missing, "empty": _empty, "truncated": _truncated, "garbage": _garbage}


def _edit_json(edit: Callable[[Any], Any]) -> Callable[[Path], None]:
    return lambda path: path.write_text(json.dumps(edit(json.loads(path.read_text()))))


def _set(key: str, value: Any) -> Callable[[dict[str, Any]], dict[str, Any]]:
    return lambda record: {**record, key: value}


def _drop(key: str) -> Callable[[dict[str, Any]], dict[str, Any]]:
    return lambda record: {name: value for name, value in record.items() if name != key}


JSON_DAMAGES = {
    "scrambled_middle": _scrambled_middle,
    "hand_edited_invalid": lambda path: path.write_text(path.read_text().replace('"settings":', '"settings"', 1)),
    "not_an_object": lambda path: path.write_text("[1, 2, 3]"),
    "other_version": _edit_json(_set("format_version", 99)),
    "nonsense_settings": _edit_json(_set("settings", "nonsense")),
    "no_settings": _edit_json(_drop("settings")),
}


def _edit_torch(edit: Callable[[Any], Any]) -> Callable[[Path], None]:
    return lambda path: torch.save(edit(torch.load(path, weights_only=True)), path)


TORCH_DAMAGES = {
    "scrambled_middle": _scrambled_middle,
    "other_version": _edit_torch(_set("format", "sumo-rail checkpoint 99")),
    "not_a_checkpoint": _edit_torch(lambda checkpoint: {"weights": torch.zeros(3)}),
    "not_a_dict": _edit_torch(lambda checkpoint: [1, 2, 3]),
    "missing_entry": _edit_torch(_drop("rng")),
    "nonsense_values": _edit_torch(_set("rng", {"state": "nonsense"})),
    "nonsense_discriminator": _edit_torch(_set("discriminator", {"model": {}, "optimizer": 1, "generator": 2})),
    "other_policy_size": _edit_torch(_set("parameters", torch.zeros(7))),
    "inconsistent_log": _edit_torch(_set("log", [])),
    "unsafe_to_load": _edit_torch(_set("extra", fractions.Fraction(1, 3))),  # weights_only refuses to unpickle it
}


def _edit_npz(edit: Callable[[dict[str, np.ndarray]], dict[str, np.ndarray]]) -> Callable[[Path], None]:
    def damage(path: Path) -> None:
        with np.load(path, allow_pickle=False) as archive:
            fields = {key: archive[key] for key in archive.files}
        with open(path, "wb") as handle:
            np.savez(handle, **edit(fields))
    return damage


def _nan_parameters(fields: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {**fields, "parameters": np.full_like(fields["parameters"], np.nan)}


NPZ_DAMAGES = {
    "scrambled_middle": _scrambled_middle,
    "other_version": _edit_npz(_set("format_version", np.array(99))),
    "not_a_policy": _edit_npz(lambda fields: {"weights": np.zeros(3)}),
    "missing_field": _edit_npz(_drop("parameters")),
    "nonsense_version": _edit_npz(_set("format_version", np.array("one"))),
    "nonsense_kind": _edit_npz(_set("kind", np.array("bicycle"))),
    "non_finite": _edit_npz(_nan_parameters),
    "metadata_not_json": _edit_npz(_set("metadata", np.array("{oops"))),
    "metadata_not_an_object": _edit_npz(_set("metadata", np.array("[1, 2]"))),
    "pickled_object": _edit_npz(_set("metadata", np.array([{"a": 1}], dtype=object))),
}


def _edit_parquet(edit_table: Callable[[pa.Table], pa.Table] | None = None,
                  edit_metadata: Callable[[bytes], bytes | None] | None = None) -> Callable[[Path], None]:
    def damage(path: Path) -> None:
        table = pq.read_table(path)
        metadata = dict(table.schema.metadata)
        if edit_metadata is not None:
            raw = edit_metadata(metadata[METADATA_KEY])
            metadata.pop(METADATA_KEY)
            if raw is not None:
                metadata[METADATA_KEY] = raw
        if edit_table is not None:
            table = edit_table(table)
        pq.write_table(table.replace_schema_metadata(metadata), path)
    return damage


def _edit_provenance(key: str, value: Any) -> Callable[[bytes], bytes]:
    return lambda raw: json.dumps({**json.loads(raw), key: value}).encode()


def _as_text(table: pa.Table) -> pa.Table:
    return pa.table({name: pa.array([str(value) for value in table[name].to_pylist()]) for name in table.column_names})


def _damaged_page(path: Path) -> None:
    """16 bytes overwritten in the middle of the first column's data: a bad sector where every reader looks (the
    middle of a small file is often the footer's second copy of the metadata, which damages nothing)."""
    chunk = pq.ParquetFile(path).metadata.row_group(0).column(0)
    data = bytearray(path.read_bytes())
    middle = chunk.data_page_offset + chunk.total_compressed_size // 2
    data[middle:middle + 16] = np.random.default_rng(2).bytes(16)
    path.write_bytes(bytes(data))


PARQUET_DAMAGES = {
    "damaged_page": _damaged_page,
    "other_version": _edit_parquet(edit_metadata=_edit_provenance("format_version", 99)),
    "other_kind": _edit_parquet(edit_metadata=_edit_provenance("kind", "something_else")),
    "no_metadata": _edit_parquet(edit_metadata=lambda raw: None),
    "metadata_not_json": _edit_parquet(edit_metadata=lambda raw: b"{oops"),
    "metadata_not_an_object": _edit_parquet(edit_metadata=lambda raw: b"[1, 2]"),
    "no_rows": _edit_parquet(lambda table: table.slice(0, 0)),
    "columns_renamed": _edit_parquet(lambda table: table.rename_columns([f"c{i}" for i in range(table.num_columns)])),
    "columns_as_text": _edit_parquet(_as_text),
}

FORMAT_DAMAGES = {"json": JSON_DAMAGES, "torch": TORCH_DAMAGES, "npz": NPZ_DAMAGES, "parquet": PARQUET_DAMAGES}


def damage_function(file: str, damage: str) -> Callable[[Path], None]:
    return GENERIC.get(damage) or FORMAT_DAMAGES[FILES[file].format][damage]


DAMAGES = [(file, damage) for file, spec in FILES.items() for damage in [*GENERIC, *FORMAT_DAMAGES[spec.format]]]
"""The table: every file with every damage that fits its format."""

# ---------------------------------------------------------------------------------------------------------------------
# Readers: which command reads which file, run in the workspace (paths relative to it).



def train_args(iterations: int = 1) -> tuple[str, ...]:
    """How the workspace's run was made (with --iterations 1)."""
    return ("train", *SMALL, "--demos", "demos.parquet", "--policy", "mlp", "--hidden", "4", "--directions", "2",
            "--top", "1", "--iterations", str(iterations), "--bc-epochs", "1", "--eval-every", "0", "--workers", "1")


TRAIN_ARGS = train_args()


@dataclass(frozen=True)
class Reader:
    file: str
    command: str
    args: tuple[str, ...]
    optional: bool = False
    """The command works without the file (a missing one is no damage)."""
    control: bool = True
    """Whether the undamaged workspace is cheap to run through the command (a check that the args are right)."""


READERS = [
    Reader("run.json", "train --resume", (*TRAIN_ARGS, "--out", "run", "--resume")),
    Reader("run.json", "report", ("report", "run", "metrics.parquet", "--out", "../report"), optional=True),
    Reader("checkpoint.pt", "train --resume", (*TRAIN_ARGS, "--out", "run", "--resume")),
    Reader("policy_bc.npz", "report", ("report", "run", "--out", "../report"), optional=True),
    Reader("policy_bc.npz", "evaluate", ("evaluate", *SMALL, "--policy", "run/policy_bc.npz", "--episodes", "1"),
           control=False),
    Reader("policy_latest.npz", "report", ("report", "run", "--out", "../report"), optional=True),
    Reader("policy_latest.npz", "evaluate", ("evaluate", *SMALL, "--policy", "run/policy_latest.npz",
                                             "--episodes", "1")),
    Reader("log.parquet", "report", ("report", "run", "--out", "../report")),
    Reader("demonstrations", "train", (*TRAIN_ARGS, "--out", "new_run"), control=False),
    Reader("demonstrations", "train --resume", (*TRAIN_ARGS, "--out", "run", "--resume")),
    Reader("demonstrations", "gail", ("gail", *SMALL, "--demos", "demos.parquet", "--timesteps", "32", "--envs", "1",
                                      "--n-steps", "32", "--bc-epochs", "1", "--out", "gail_run"), control=False),
    Reader("metrics", "report", ("report", "metrics.parquet", "--out", "../report")),
    # dagger and the exports join here, e.g. Reader("demonstrations", "dagger", ("dagger", ...)).
]

CASES = [pytest.param(file, damage, reader, id=f"{file}-{damage}-{reader.command.replace(' ', '')}")
         for file, damage in DAMAGES for reader in READERS if reader.file == file]

# ---------------------------------------------------------------------------------------------------------------------
# The workspace and the checks.


@pytest.fixture(scope="module")
def template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small real workspace: demos.parquet (2 episodes), run/ (one RAIL iteration), metrics.parquet (1 episode)."""
    folder = tmp_path_factory.mktemp("workspace")
    previous = Path.cwd()
    os.chdir(folder)
    try:
        for args in (("record-expert", *SMALL, "--episodes", "2", "--out", "demos.parquet"),
                     (*TRAIN_ARGS, "--out", "run"),
                     ("evaluate", *SMALL, "--policy", "keep", "--episodes", "1", "--out", "metrics.parquet")):
            result = CliRunner().invoke(cli, list(args))
            assert result.exit_code == 0, result.output
    finally:
        os.chdir(previous)
    return folder


@pytest.fixture
def workspace(template: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A copy of the template, made the working directory (the run's settings hold relative paths)."""
    folder = tmp_path / "workspace"
    shutil.copytree(template, folder)
    monkeypatch.chdir(folder)
    return folder


def fingerprint(folder: Path) -> dict[str, str]:
    """Every file and folder under `folder` with its content's hash."""
    return {str(path.relative_to(folder)): hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else "dir"
            for path in sorted(folder.rglob("*"))}


def assert_one_sentence(result: Result, name: str) -> str:
    """The command failed with one click error line naming `name`, no traceback; returns the message."""
    assert isinstance(result.exception, SystemExit), f"unhandled {result.exception!r}\n{result.output}"
    assert result.exit_code in (1, 2), result.output
    assert "Traceback" not in result.output
    lines = result.stderr.rstrip().splitlines()
    errors = [line for line in lines if line.startswith("Error: ")]
    assert len(errors) == 1 and lines[-1] == errors[0], result.stderr  # one line, the last
    message = errors[0].removeprefix("Error: ")
    assert name in message, message
    assert " ()" not in message and len(message.replace(name, "").split()) >= 3, message  # says what is wrong
    return message


@pytest.mark.parametrize(("file", "damage", "reader"), CASES)
def test_a_damaged_file_is_one_sentence_and_changes_nothing(workspace: Path, file: str, damage: str, reader: Reader):
    path = workspace / FILES[file].path
    damage_function(file, damage)(path)
    before = fingerprint(workspace)
    result = CliRunner().invoke(cli, list(reader.args))
    if damage == "missing" and reader.optional:
        assert result.exit_code == 0, result.output
    else:
        assert_one_sentence(result, path.name)
    assert fingerprint(workspace) == before


@pytest.mark.parametrize("reader", [reader for reader in READERS if reader.control],
                         ids=lambda reader: f"{reader.file}-{reader.command.replace(' ', '')}")
def test_the_undamaged_workspace_works_with_every_reader(workspace: Path, reader: Reader):
    """The control: the readers' arguments are right, so the failures above come from the damage."""
    result = CliRunner().invoke(cli, list(reader.args))
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize(("file", "damage", "command"), [
    ("run.json", "hand_edited_invalid", "train --resume"),
    ("checkpoint.pt", "empty", "train --resume"),
])
def test_a_real_process_prints_one_line_and_exits_1(workspace: Path, file: str, damage: str, command: str):
    """As a user sees it: the exit status and stderr of a real process, not click's test runner."""
    reader = next(reader for reader in READERS if reader.file == file and reader.command == command)
    damage_function(file, damage)(workspace / FILES[file].path)
    before = fingerprint(workspace)
    result = subprocess.run([sys.executable, "-m", "sumo_rail_cli", *reader.args], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 1 and "Traceback" not in result.stderr, result.stderr
    error = result.stderr.rstrip().splitlines()[-1]
    assert error.startswith("Error: ") and Path(FILES[file].path).name in error
    assert fingerprint(workspace) == before


# ---------------------------------------------------------------------------------------------------------------------
# Full disk while an iteration is saved.

WRITERS = {
    "policy_latest.npz": (np, "savez", 0),  # the first file an iteration writes
    "log.parquet": (pq, "write_table", 1),
    "checkpoint.pt": (torch, "save", 1),  # the last (discriminator.pt is written as it is)
}
"""File -> (module, writer function, index of its destination argument): one per writer."""


@pytest.mark.parametrize("file", list(WRITERS))
def test_a_full_disk_during_a_save_keeps_the_previous_iteration(workspace: Path, monkeypatch: pytest.MonkeyPatch,
                                                                 file: str):
    module, name, where = WRITERS[file]
    original = getattr(module, name)

    def write_half_then_fail(*args: Any, **kwargs: Any) -> Any:
        destination = args[where]
        target = str(getattr(destination, "name", destination))
        if file not in Path(target).name:
            return original(*args, **kwargs)
        if hasattr(destination, "write"):
            destination.write(b"PK\x03\x04 half")
        else:
            Path(target).write_bytes(b"half")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    run = workspace / "run"
    before = fingerprint(run)
    monkeypatch.setattr(module, name, write_half_then_fail)
    args = [*train_args(iterations=2)]
    result = CliRunner().invoke(cli, [*args, "--out", "run", "--resume"])
    message = assert_one_sentence(result, "run")
    assert os.strerror(errno.ENOSPC) in message and "iteration 1" in message and "--resume" in message
    assert fingerprint(run) == before  # the previous complete iteration, untouched; no temporary left behind
    if file == "checkpoint.pt":  # once there is room again, resume continues
        monkeypatch.setattr(module, name, original)
        result = CliRunner().invoke(cli, [*args, "--out", "run", "--resume"])
        assert result.exit_code == 0, result.output
        assert pd.read_parquet(run / "log.parquet")["iteration"].tolist() == [0, 1]


def test_a_full_disk_during_a_gail_update_keeps_the_previous_update(workspace: Path,
                                                                    monkeypatch: pytest.MonkeyPatch):
    from sumo_rail.learning.sb3.gail import GailSettings, train_gail
    from sumo_rail.learning.sb3.runs import BaselineError

    original, saved = pq.write_table, {}

    def fail_from_the_second_update(row: dict[str, Any]) -> None:
        saved.update(fingerprint(workspace / "gail_run"))

        def write_half_then_fail(table: pa.Table, where: Any, **kwargs: Any) -> None:
            Path(where).write_bytes(b"half")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        monkeypatch.setattr(pq, "write_table", write_half_then_fail)

    settings = GailSettings("demos.parquet", timesteps=64, envs=1, n_steps=32, batch_size=32, bc_epochs=1)
    with pytest.raises(BaselineError) as caught:
        train_gail(workspace / "gail_run", settings, SMALL_CONFIG, on_update=fail_from_the_second_update)
    monkeypatch.setattr(pq, "write_table", original)
    message = str(caught.value)
    assert "cannot save update 2" in message and os.strerror(errno.ENOSPC) in message
    assert "keeps update 1, the last complete one: make room and continue with --resume" in message
    assert saved and fingerprint(workspace / "gail_run") == saved  # update 1's files, untouched; no temporary left
    assert pd.read_parquet(workspace / "gail_run" / "log.parquet")["iteration"].tolist() == [0]
    assert train_gail(workspace / "gail_run", settings, SMALL_CONFIG, resume=True).updates == 2  # room again
    assert pd.read_parquet(workspace / "gail_run" / "log.parquet")["iteration"].tolist() == [0, 1]


# ---------------------------------------------------------------------------------------------------------------------
# Caches: a damaged entry is rebuilt, never fatal.

CACHE_FILES = {"network": "networks/*/highway.net.xml", "routes": "networks/*/traffic.rou.xml",
               "warm state": "states/*/state_001.xml"}


def _valid_but_other_state(path: Path) -> None:
    path.write_text('<?xml version="1.0"?>\n<snapshot time="5.00" version="0.1"/>\n')


CACHE_DAMAGES = [(file, damage) for file in CACHE_FILES for damage in ("missing", "empty", "truncated", "garbage")]
CACHE_DAMAGES += [("warm state", "other_snapshot"), ("network", "scrambled_middle")]


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
    (GENERIC.get(damage) or _valid_but_other_state)(path)
    simulation = Simulation(SMALL_CONFIG.scenario, 100.0)
    try:
        simulation.reset(1, 7, 0, 300.0)
        simulation.advance(10)
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
        for damage in (None, _truncated):
            if damage is not None:
                [path] = cache.glob(CACHE_FILES[file])
                damage(path)
            simulation.reset(1, 7, 2, 300.0)
            simulation.advance(20)
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
        _truncated(path)
    damaged = CliRunner().invoke(cli, [*evaluate, str(tmp_path / "damaged.parquet")])
    assert damaged.exit_code == 0, damaged.output
    for path, intact_state in states.items():  # rebuilt: the same state again
        assert path.read_bytes().split(b"<snapshot", 1)[-1] == intact_state.split(b"<snapshot", 1)[-1], path.name
    for name in ("{}.parquet", "{}.decisions.parquet"):  # the same episodes and decisions
        pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / name.format("damaged")),
                                      pd.read_parquet(tmp_path / name.format("intact")))


# ---------------------------------------------------------------------------------------------------------------------
# Worker loss under gail and ppo.


def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(child) for child in text.split()]


def _is_env_process(pid: int) -> bool:
    try:
        command = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
    except OSError:
        return False
    return b"multiprocessing" in command and b"resource_tracker" not in command


LOSING_RUNS = {
    "GAIL": ["gail", *SMALL, "--demos", "demos.parquet", "--timesteps", "100000", "--envs", "1", "--n-steps", "32",
             "--bc-epochs", "1", "--out", "sb3_run"],
    "PPO": ["ppo", *SMALL, "--timesteps", "100000", "--envs", "1", "--n-steps", "32", "--out", "sb3_run"],
    "PPO with two egos a process": ["ppo", *SMALL, "--timesteps", "100000", "--envs", "1", "--egos", "2",
                                    "--n-steps", "32", "--out", "sb3_run"],
}


@pytest.mark.parametrize("run", sorted(LOSING_RUNS))
@pytest.mark.parametrize("how", ["killed", "failing"])
def test_a_lost_stable_baselines3_environment_process_is_one_sentence(workspace: Path, tmp_path: Path, how: str,
                                                                       run: str):
    """An env process killed mid-run (kill -9), or one that fails as it starts (its cache is a file, not a folder):
    one sentence saying which process and what the run folder holds; no EOFError, no traceback from any process."""
    environment = dict(os.environ)
    if how == "failing":
        environment["SUMO_RAIL_CACHE"] = str(tmp_path / "not_a_folder")
        (tmp_path / "not_a_folder").write_text("")
    command = [sys.executable, "-m", "sumo_rail_cli", *LOSING_RUNS[run]]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=environment)
    try:
        if how == "killed":
            deadline = time.time() + 120
            while not (workspace / "sb3_run" / "log.parquet").exists() and time.time() < deadline:
                time.sleep(0.2)
            assert (workspace / "sb3_run" / "log.parquet").exists(), "no update was saved within 120 s"
            envs = [pid for pid in _children(process.pid) if _is_env_process(pid)]
            assert len(envs) == 1, envs
            os.kill(envs[0], signal.SIGKILL)
        _, stderr = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert process.returncode == 1 and "Traceback" not in stderr and "EOFError" not in stderr, stderr
    error = stderr.rstrip().splitlines()[-1]
    assert error.startswith(f"Error: {run.split()[0]} stopped during update "), error
    if how == "killed":
        assert "environment process 0 was killed by signal 9" in error and "keeps update " in error \
            and error.endswith("the last complete one: continue with --resume")
    else:
        assert "environment process 0 failed: " in error and "not_a_folder" in error and "no complete update" in error
