"""Reliability: nothing a disk, a crash or a person does to the files sumo-rail reads back gets a traceback.

Damaged inputs. `DAMAGES` is one table of (file, damage) pairs; `READERS` says which command reads which file.
Each case copies a small real workspace made once per test session (`reliability.make_workspace`: demonstrations, a
one-iteration RAIL run folder, a metrics file), damages one file, runs the command through click and checks that it
answers with one sentence naming the file (exit 1, or 2 for a usage error), prints no traceback and leaves every
file of the workspace as it was, byte for byte. A new file joins with a `FILES` entry (its damages follow from its
format); a new command joins with rows of `READERS`.

Damaged caches: tests/test_cache_repair.py; full disk and lost worker processes: tests/test_reliability_runs.py.
"""

from __future__ import annotations

import fractions
import json
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import torch
from click.testing import CliRunner
from reliability import GENERIC, TRAIN_ARGS, assert_one_sentence, fingerprint, scrambled_middle
from sumo_rail_cli.main import cli
from test_cli import SMALL

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
# Damages that depend on a file's format (`reliability.GENERIC` has those of every file).


def _edit_json(edit: Callable[[Any], Any]) -> Callable[[Path], None]:
    return lambda path: path.write_text(json.dumps(edit(json.loads(path.read_text()))))


def _set(key: str, value: Any) -> Callable[[dict[str, Any]], dict[str, Any]]:
    return lambda record: {**record, key: value}


def _drop(key: str) -> Callable[[dict[str, Any]], dict[str, Any]]:
    return lambda record: {name: value for name, value in record.items() if name != key}


JSON_DAMAGES = {
    "scrambled_middle": scrambled_middle,
    "hand_edited_invalid": lambda path: path.write_text(path.read_text().replace('"settings":', '"settings"', 1)),
    "not_an_object": lambda path: path.write_text("[1, 2, 3]"),
    "other_version": _edit_json(_set("format_version", 99)),
    "nonsense_settings": _edit_json(_set("settings", "nonsense")),
    "no_settings": _edit_json(_drop("settings")),
}


def _edit_torch(edit: Callable[[Any], Any]) -> Callable[[Path], None]:
    return lambda path: torch.save(edit(torch.load(path, weights_only=True)), path)


TORCH_DAMAGES = {
    "scrambled_middle": scrambled_middle,
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
    "scrambled_middle": scrambled_middle,
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
    Reader("demonstrations", "gail", ("gail", *SMALL, "--demos", "demos.parquet", "--timesteps", "32", "--set",
    "gail.envs=1",
                                      "--set", "gail.n_steps=32", "--set", "bc.epochs=1", "--out", "gail_run"),
                                      control=False),
    Reader("metrics", "report", ("report", "metrics.parquet", "--out", "../report")),
    Reader("demonstrations", "export-minari", ("export-minari", "demos.parquet", "--name", "sumo-rail/damaged-v0",
                                               "--root", "../minari")),
    Reader("demonstrations", "dagger", ("dagger", *SMALL, "--demos", "demos.parquet", "--rounds", "1", "--set",
                                        "bc.epochs=1", "--eval-every", "0", "--workers", "1", "--out", "dagger_run")),
]

CASES = [pytest.param(file, damage, reader, id=f"{file}-{damage}-{reader.command.replace(' ', '')}")
         for file, damage in DAMAGES for reader in READERS if reader.file == file]

# ---------------------------------------------------------------------------------------------------------------------
# The checks.


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


