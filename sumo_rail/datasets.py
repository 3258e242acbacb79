"""Parquet files every stage writes and reads: provenance metadata, atomic writes, checked output paths.

Every file carries JSON provenance under the Parquet schema metadata key `sumo_rail`: the table kind, the full
config, the seed, the observation layout and the versions of SUMO, sumo-rail, pyarrow, numpy and Python.
Nothing time-dependent is stored, so the same job writes the same bytes. The table schemas live with the
runners that write them (`sumo_rail.runners.tables`).
"""

from __future__ import annotations

import json
import os
import platform
from importlib import metadata as package_metadata
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

METADATA_KEY = b"sumo_rail"
FORMAT_VERSION = 1


class DatasetError(ValueError):
    """A data file or output path a user supplied cannot be used (message is one sentence)."""


def sumo_version() -> str:
    """Version of the installed eclipse-sumo package."""
    return package_metadata.version("eclipse-sumo")


def versions() -> dict[str, str]:
    """Versions of what shapes the results."""
    return {"sumo": sumo_version(), "sumo_rail": package_metadata.version("sumo-rail"), "pyarrow": pa.__version__,
            "numpy": np.__version__, "python": platform.python_version()}


def check_output_path(path: Path, overwrite: bool) -> None:
    """Fail before any work if `path` cannot be written (exists without `overwrite`, folder missing, read-only)."""
    path = Path(path)
    if path.is_dir():
        raise DatasetError(f"output {path} is a folder, not a file")
    if path.exists() and not overwrite:
        raise DatasetError(f"output {path} already exists; pass --overwrite to replace it")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise DatasetError(f"the folder of output {path} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise DatasetError(f"the folder of output {path} is not writable")


def write_parquet(table: pa.Table, path: Path, metadata: dict[str, Any]) -> None:
    """Write `table` with `metadata` to `path` atomically: a temporary file in the same folder, then rename."""
    path = Path(path)
    schema_metadata = {**(table.schema.metadata or {}), METADATA_KEY: json.dumps(metadata, sort_keys=True).encode()}
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        pq.write_table(table.replace_schema_metadata(schema_metadata), temporary)
        os.replace(temporary, path)
    except OSError as error:
        raise DatasetError(f"cannot write {path}: {error.strerror or error}") from error
    finally:
        temporary.unlink(missing_ok=True)


def read_metadata(path: Path) -> dict[str, Any]:
    """The sumo-rail provenance of a Parquet file written by this package."""
    schema = _read_schema(Path(path))
    raw = (schema.metadata or {}).get(METADATA_KEY)
    if raw is None:
        raise DatasetError(f"{path} has no sumo-rail metadata; it was not written by sumo-rail")
    try:
        return json.loads(raw)
    except json.JSONDecodeError as error:
        raise DatasetError(f"{path} has unreadable sumo-rail metadata ({error})") from error


def _read_schema(path: Path) -> pa.Schema:
    if not path.is_file():
        raise DatasetError(f"file {path} does not exist")
    try:
        return pq.read_schema(path)
    except (pa.ArrowException, OSError) as error:
        raise DatasetError(f"{path} is not a readable Parquet file ({error})") from error
