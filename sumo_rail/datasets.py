"""Parquet files every stage writes and reads: provenance metadata, atomic writes, checked output paths.

Every file carries JSON provenance under the Parquet schema metadata key `sumo_rail`: the table kind, the full
config, the seed, the observation layout and the versions of Python and of the packages that shape results (SUMO,
sumo-rail, numpy, pyarrow, torch, numba, gymnasium and, where installed, Stable-Baselines3).
Nothing time-dependent is stored, so the same job writes the same bytes. The table schemas live with the
runners that write them (`sumo_rail.runners.tables`). Pages carry CRC checksums, verified on read, so a damaged
file is an error rather than wrong numbers. Every reader answers a missing, empty, truncated, damaged or foreign file
with a one-sentence `DatasetError` naming it (`describe` keeps library messages to one line).
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager
from importlib import metadata as package_metadata
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

METADATA_KEY = b"sumo_rail"
FORMAT_VERSION = 1


class DatasetError(ValueError):
    """A data file or output path a user supplied cannot be used (message is one sentence)."""


def sumo_version() -> str:
    """Version of the installed eclipse-sumo package."""
    return package_metadata.version("eclipse-sumo")


VERSIONED_PACKAGES = {"sumo": "eclipse-sumo", "sumo_rail": "sumo-rail", "numpy": "numpy", "pyarrow": "pyarrow",
                      "torch": "torch", "numba": "numba", "gymnasium": "gymnasium",
                      "stable_baselines3": "stable-baselines3"}  # key in the provenance: distribution name


def versions() -> dict[str, str]:
    """Versions of Python and of the installed packages that shape the results (GAIL's Stable-Baselines3 is
    optional and left out when it is not installed)."""
    found = {"python": platform.python_version()}
    for key, distribution in VERSIONED_PACKAGES.items():
        try:
            found[key] = package_metadata.version(distribution)
        except package_metadata.PackageNotFoundError:
            continue
    return found


def check_output_path(path: Path, overwrite: bool) -> None:
    """Fail before any work if `path` cannot be written (exists without `overwrite`, folder missing, read-only)."""
    path = Path(path)
    if path.is_dir():
        raise DatasetError(f"output {path} is a folder, not a file")
    if path.exists() and not overwrite:
        raise DatasetError(f"output {path} already exists; pass --overwrite to replace it")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        blocking = file_in_the_way(folder)
        if blocking is not None:
            raise DatasetError(f"the folder of output {path} cannot be: {blocking} is a file, not a folder")
        raise DatasetError(f"the folder of output {path} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise DatasetError(f"the folder of output {path} is not writable")


def file_in_the_way(folder: Path) -> Path | None:
    """The file (not a folder) that `folder` is, or is inside, so that it cannot exist; None when there is none."""
    existing = next((parent for parent in (folder, *folder.parents) if parent.exists()), None)
    return existing if existing is not None and not existing.is_dir() else None


def check_output_folder(folder: Path) -> None:
    """Fail before any work if the run folder `folder` cannot be made or written: it is a file, or the folder it is
    (or would be made) in is not a folder or not writable (read-only)."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise DatasetError(f"{folder} is a file, not a folder")
    existing = next(parent for parent in (folder, *folder.parents, Path(".")) if parent.exists())
    if not existing.is_dir():
        raise DatasetError(f"run folder {folder} cannot be made: {existing} is a file")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise DatasetError(f"run folder {folder} cannot be written: {existing} is not writable")


@contextmanager
def written_atomically(path: Path, suffix: str = "") -> Iterator[Path]:
    """The one way sumo-rail replaces a file: write to the temporary path this yields (a hidden name of this process
    in the same folder, ending in `suffix` for writers that go by the extension); when the block succeeds it is
    renamed onto `path` in one step, so a reader sees the old file or the new one, never half of one. The temporary
    file is removed in any case."""
    path = Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp{suffix}")
    try:
        yield temporary
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


@contextmanager
def write_failures(path: Path, error: type[Exception]) -> Iterator[None]:
    """Raise an OSError of the block, which writes `path`, as `error`: "cannot write PATH: reason" (one sentence)."""
    try:
        yield
    except OSError as exc:
        raise error(f"cannot write {path}: {exc.strerror or exc}") from exc


def write_bytes_atomically(path: Path, content: bytes) -> None:
    """Write `content` to `path` with `written_atomically`."""
    with written_atomically(path) as temporary:
        temporary.write_bytes(content)


def write_parquet(table: pa.Table, path: Path, metadata: dict[str, Any]) -> None:
    """Write `table` with `metadata` to `path` atomically (`written_atomically`)."""
    path = Path(path)
    schema_metadata = {**(table.schema.metadata or {}), METADATA_KEY: json.dumps(metadata, sort_keys=True).encode()}
    with write_failures(path, DatasetError), written_atomically(path) as temporary:
        pq.write_table(table.replace_schema_metadata(schema_metadata), temporary, write_page_checksum=True)


def file_sha256(path: Path) -> str:
    """SHA-256 of a file's bytes, in hex: how outputs pin the inputs they record by path."""
    digest = hashlib.sha256()
    with open(path, "rb") as file:
        for block in iter(lambda: file.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def describe(error: BaseException) -> str:
    """`error` in one line: the first line of its message (at most 300 characters), else its type's name."""
    text = next((line.strip() for line in str(error).splitlines() if line.strip()), "")
    if len(text) > 300:
        text = text[:297] + "..."
    return text or type(error).__name__


def write_failure(error: BaseException) -> str:
    """Why a write failed, in a few words: the operating system's reason ("No space left on device") when an
    OSError is behind `error`, else `describe(error)`."""
    cause: BaseException | None = error
    while cause is not None:
        if isinstance(cause, OSError) and cause.strerror:
            return cause.strerror
        cause = cause.__cause__
    return describe(error)


def check_file(path: Path, what: str) -> None:
    """DatasetError unless `path` is a non-empty file; `what` names it in the message ("policy file", ...)."""
    if not path.exists():
        raise DatasetError(f"{what} {path} does not exist")
    if not path.is_file():
        raise DatasetError(f"{what} {path} is not a file")
    if path.stat().st_size == 0:
        raise DatasetError(f"{what} {path} is empty (0 bytes)")


def read_metadata(path: Path) -> dict[str, Any]:
    """The sumo-rail provenance of a Parquet file written by this package, of this format version."""
    schema = _read_schema(Path(path))
    raw = (schema.metadata or {}).get(METADATA_KEY)
    if raw is None:
        raise DatasetError(f"{path} has no sumo-rail metadata; it was not written by sumo-rail")
    try:
        metadata = json.loads(raw)
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise DatasetError(f"{path} has unreadable sumo-rail metadata ({describe(error)})") from error
    if not isinstance(metadata, dict):
        raise DatasetError(f"{path} has sumo-rail metadata that is not a JSON object")
    check_format_version(metadata, path)
    return metadata


def check_format_version(record: dict[str, Any], path: Path) -> None:
    """DatasetError when `record` (provenance) says another format version than this sumo-rail's."""
    version = record.get("format_version", FORMAT_VERSION)
    if version != FORMAT_VERSION:
        raise DatasetError(f"{path} has format version {version!r}; this sumo-rail reads version {FORMAT_VERSION}")


def read_table(path: Path, columns: list[str] | None = None) -> pa.Table:
    """The table in `path` (or its `columns`), its page checksums verified; DatasetError naming the file if the
    file is unreadable or lacks a column."""
    try:
        return pq.read_table(path, columns=columns, page_checksum_verification=True)
    except (pa.ArrowException, OSError, ValueError) as error:
        raise DatasetError(f"{path} is damaged or not a readable Parquet file ({describe(error)})") from error


def read_json_record(path: Path, what: str) -> dict[str, Any]:
    """A JSON object written by sumo-rail (e.g. a run folder's run.json), of this format version; DatasetError
    naming the file when it is missing, empty, not JSON, not an object or of another version."""
    path = Path(path)
    check_file(path, what)
    try:
        record = json.loads(path.read_bytes())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise DatasetError(f"{what} {path} is not readable JSON ({describe(error)})") from error
    if not isinstance(record, dict):
        raise DatasetError(f"{what} {path} is not a JSON object")
    check_format_version(record, path)
    return record


def _read_schema(path: Path) -> pa.Schema:
    check_file(path, "file")
    try:
        return pq.read_schema(path)
    except (pa.ArrowException, OSError, ValueError) as error:
        raise DatasetError(f"{path} is not a readable Parquet file ({describe(error)})") from error


@contextmanager
def written_together(folder: Path) -> Iterator[StagedFiles]:
    """Write several files of `folder` as one: each writer writes to `staged.path(final)`; only when every write
    succeeded are they renamed into place, in the order staged (so stage the file that marks completion last).
    On any failure the staged files are removed and the files already in `folder` stay as they were."""
    staged = StagedFiles(Path(folder))
    try:
        yield staged
    except BaseException:
        staged.discard()
        raise
    staged.commit()


class StagedFiles:
    """Temporary files waiting to replace their final paths, each one `written_atomically`; see `written_together`."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self._staged: list[AbstractContextManager[Path]] = []

    def path(self, final: Path) -> Path:
        """Where to write `final` for now (a hidden name in the same folder, so the rename is atomic)."""
        staged = written_atomically(final)
        temporary = staged.__enter__()
        self._staged.append(staged)
        return temporary

    def commit(self) -> None:
        """Rename every staged file into place, in the order staged."""
        for staged in self._staged:
            staged.__exit__(None, None, None)
        self._staged.clear()

    def discard(self) -> None:
        """Remove every staged file; the final paths stay as they were."""
        for staged in self._staged:
            staged.__exit__(_Discarded, _Discarded(), None)
        self._staged.clear()


class _Discarded(Exception):
    """What a discarded staged write is left with (`StagedFiles.discard`): its temporary file is removed, nothing
    renamed."""
