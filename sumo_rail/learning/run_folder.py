"""The run folder every training command (`train`, `dagger`, `gail`, `ppo`) writes: starting it (a new or empty
folder and its run.json), resuming it (the same settings, a whole checkpoint), and stopping on Ctrl-C or SIGTERM
without leaving an iteration's files half written.

run.json holds the run's settings, config and provenance; each command adds its own files and a checkpoint, which it
writes last, so the checkpoint marks the last complete step (`written_together`).
"""

from __future__ import annotations

import dataclasses
import json
import pickle
import signal
import threading
import zipfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import torch

from sumo_rail.config import Config
from sumo_rail.datasets import (
    DatasetError,
    describe,
    file_sha256,
    read_json_record,
    write_bytes_atomically,
    write_failure,
)
from sumo_rail.learning.bc import BcSettings
from sumo_rail.runners.tables import ROAD_FILES


class RunError(ValueError):
    """A run folder cannot be used as asked (message is one sentence)."""


COMMANDS = {"training_run": "train", "dagger_run": "dagger", "gail_run": "gail", "ppo_run": "ppo"}
"""The command that makes a run folder of each run.json kind."""


def start_run_folder(folder: Path, run_record: dict[str, Any]) -> None:
    """Make the new or empty run `folder` (and its parents) with its run.json; a RunError, one sentence, when it is
    not empty (advising --resume only where this command could continue it) or cannot be made."""
    if folder.is_dir() and any(folder.iterdir()):
        made_by = _made_by(folder)
        if made_by is not None and made_by != run_record.get("kind"):
            raise RunError(f"run folder {folder} holds a run made by {COMMANDS.get(str(made_by), made_by)}, not by "
                           f"{COMMANDS.get(str(run_record.get('kind')), 'this command')}; choose another --out")
        if made_by is None or not any(folder.glob("checkpoint.*")):
            raise RunError(f"run folder {folder} is not empty and holds no run to continue; choose another --out")
        raise RunError(f"run folder {folder} is not empty; pass --resume to continue it or choose another --out")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        write_run_record(folder, run_record)
    except OSError as error:
        raise RunError(f"cannot make the run folder {folder} ({write_failure(error)})") from error


def write_run_record(folder: Path, run_record: dict[str, Any]) -> None:
    """Replace the run folder's run.json (atomically)."""
    write_bytes_atomically(Path(folder) / "run.json", json.dumps(run_record, indent=2, sort_keys=True).encode())


def read_run_record(folder: Path) -> dict[str, Any]:
    """The run folder's run.json, checked: a JSON object of this format version with `settings` and `config`
    objects; a RunError naming the file otherwise."""
    path = Path(folder) / "run.json"
    try:
        record = read_json_record(path, "run record")
    except DatasetError as error:
        raise RunError(str(error)) from error
    for key in ("settings", "config"):
        if not isinstance(record.get(key), dict):
            raise RunError(f"run record {path} has no {key!r} object, so it is not a sumo-rail run record")
    return record


def check_resumable(folder: Path, checkpoint: str, run_record: dict[str, Any], defaults: dict[str, Any] | None = None,
                    free: tuple[str, ...] = ()) -> dict[str, Any]:
    """The stored run.json of the run in `folder` that `run_record` continues: its `checkpoint` file exists, and it was
    started with the same settings (those added since it was written filled in from `defaults`, `with_defaults`; the
    settings named in `free`, such as the run's length, may differ), config and kind. A RunError otherwise."""
    path = Path(folder) / checkpoint
    made_by = _made_by(Path(folder))
    if made_by is not None and made_by != run_record.get("kind"):
        raise RunError(f"run {folder} was made by {COMMANDS.get(str(made_by), made_by)}, not by "
                       f"{COMMANDS.get(str(run_record.get('kind')), 'this command')}: resume it with that command")
    if not path.is_file():
        raise RunError(f"nothing to resume: {path} does not exist")
    stored = read_run_record(folder)

    def fixed(settings: dict[str, Any]) -> dict[str, Any]:
        return {key: value for key, value in settings.items() if key not in free}

    added = {"include_failed_demos": False} if "include_failed_demos" in run_record["settings"] else {}
    settings = with_defaults(upgraded(stored["settings"]), {**added, **(defaults or {})})
    if isinstance(run_record["settings"].get("demos"), str) and isinstance(settings.get("demos"), str):
        check_same_demos(folder, settings["demos"], stored.get(DEMOS_HASH), run_record)
        settings = {**settings, "demos": run_record["settings"]["demos"]}
    changed = [path for path, digest in stored.get(ROAD_FILES, {}).items()
               if run_record.get(ROAD_FILES, {}).get(path, digest) != digest]
    if changed:
        raise RunError(f"{changed[0]} has changed since run {folder} was started on it (its content hash differs); "
                       f"resume it on the file it was started with")
    defaults_now = Config().to_dict()  # a config section added since the run was started reads as its defaults
    difference = (first_difference(fixed(settings), fixed(run_record["settings"]))
                  or first_difference(with_defaults(stored["config"], defaults_now),
                                      with_defaults(run_record["config"], defaults_now)))
    if difference is not None or stored.get("kind") != run_record.get("kind"):
        said = f" ({difference})" if difference is not None else ""
        raise RunError(f"run {folder} was started with other settings{said}; resume it with the settings of its "
                       f"run.json")
    return stored


def first_difference(stored: Any, given: Any, key: str = "") -> str | None:
    """The first setting, by dotted key, whose value in the nested settings `stored` differs from `given`, said as
    "KEY was V, now W"; None when they are equal."""
    if isinstance(stored, dict) and isinstance(given, dict):
        for name in sorted(set(stored) | set(given)):
            found = first_difference(stored.get(name), given.get(name), f"{key}.{name}" if key else name)
            if found is not None:
                return found
        return None
    return None if stored == given else f"{key} was {stored!r}, now {given!r}"


def _made_by(folder: Path) -> Any:
    """The kind of the run in `folder` as its run.json says (None without a readable one)."""
    try:
        return read_run_record(folder).get("kind")
    except RunError:
        return None


DEMOS_HASH = "demos_sha256"
"""The run.json entry holding the content hash of the demonstrations a run learns from (`demos_record`)."""


def demos_record(demos: str | Path) -> tuple[str, dict[str, str]]:
    """The demonstrations' absolute path, as a run's settings record it (so that the run resumes from any folder),
    and the run.json entry pinning their content (`DEMOS_HASH`)."""
    path = Path(demos).resolve()
    return str(path), {DEMOS_HASH: file_sha256(path)}


def check_same_demos(folder: Path, recorded: str, digest: str | None, run_record: dict[str, Any]) -> None:
    """That the run in `folder`, started with the demonstrations `recorded` (whose content hash was `digest`;
    None in a run.json written before it was kept), continues with the same ones (`run_record`'s, absolute). A
    relative `recorded` path (an older run.json) means the file from where the command runs, as where the run was
    started. The same file moved elsewhere is the same demonstrations; a RunError naming the file otherwise."""
    given, started = Path(run_record["settings"]["demos"]), Path(recorded)
    if started.resolve() == given.resolve():
        if digest is not None and digest != run_record.get(DEMOS_HASH):
            raise RunError(f"the demonstrations {given} have changed since run {folder} was started with them (their "
                           f"content hash differs); resume it with the file it was started with")
        return
    if digest is not None and digest == run_record.get(DEMOS_HASH):
        return  # the same content: the file was moved or copied
    if not started.is_absolute():
        raise RunError(f"run {folder} was started with the demonstrations {recorded} (a path relative to the folder "
                       f"it was started from), not {given}; resume it from that folder")
    if started.is_file():
        raise RunError(f"run {folder} was started with the demonstrations {started}, not {given}; resume it with "
                       f"--demos {started}")
    raise RunError(f"run {folder} was started with the demonstrations {started}, which are gone from there (moved or "
                   f"deleted), and {given} holds other ones; resume it with --demos naming the file it started with")


def as_json(settings: dict[str, Any]) -> dict[str, Any]:
    """`settings` as run.json reads them back (tuples as lists), so a resumed run compares like with like."""
    return json.loads(json.dumps(settings))


def upgraded(settings: dict[str, Any]) -> dict[str, Any]:
    """A run.json's settings in today's layout. Before BC's settings were stored whole (the `bc` section), train and
    gail stored `bc_epochs` and later `bc_class_balance` (absent: 0, the plain cross-entropy BC was then); the rest of
    their BC was what today's defaults are, seeded with the run's seed."""
    if "bc_epochs" not in settings:
        return settings
    settings = dict(settings)
    seed = settings.get("seed", settings.get("rail", {}).get("seed", 0))
    bc = BcSettings(epochs=settings.pop("bc_epochs"), class_balance=settings.pop("bc_class_balance", 0.0), seed=seed)
    return {**settings, "bc": dataclasses.asdict(bc)}


def with_defaults(stored: dict[str, Any], defaults: dict[str, Any]) -> dict[str, Any]:
    """`stored` settings with the settings added since it was written filled in from `defaults` (nested dicts
    merged), so a run started before an option existed resumes as what it was: a run at that option's default."""
    merged = dict(stored)
    for key, default in defaults.items():
        if key not in merged:
            merged[key] = default
        elif isinstance(default, dict) and isinstance(merged[key], dict):
            merged[key] = with_defaults(merged[key], default)
    return merged


def save_tensors(state: dict[str, Any], path: Path) -> None:
    """torch.save `state` to `path` through an open file: torch names the archive's inner folder after a path it is
    given, and `path` is a temporary name holding the writer's pid (`written_atomically`), so the same state would
    give other bytes in another process (a resumed run's discriminator.pt and checkpoint.pt against an uninterrupted
    run's); through a file the folder is always "archive"."""
    with path.open("wb") as file:
        torch.save(state, file)


def load_checkpoint(path: Path, expected: str) -> dict[str, Any]:
    """A checkpoint.pt of format `expected`: its zip checksums verified (torch does not check them), loaded with
    weights_only (no code runs)."""
    if path.stat().st_size == 0:
        raise RunError(f"checkpoint {path} is empty (0 bytes)")
    try:
        with zipfile.ZipFile(path) as archive:
            damaged = archive.testzip()
    except Exception as error:  # BadZipFile, UnicodeDecodeError, OSError: truncated, overwritten or foreign
        raise RunError(f"checkpoint {path} is unreadable: truncated or not a torch checkpoint "
                       f"({describe(error)})") from error
    if damaged is not None:
        raise RunError(f"checkpoint {path} is damaged: its part {damaged} fails its checksum")
    try:
        checkpoint = torch.load(path, weights_only=True)
    except pickle.UnpicklingError as error:
        raise RunError(f"checkpoint {path} holds objects other than tensors and plain values, which sumo-rail does "
                       f"not load") from error
    except Exception as error:  # torch raises several types for damaged files
        raise RunError(f"checkpoint {path} is unreadable ({describe(error)})") from error
    if not isinstance(checkpoint, dict) or "format" not in checkpoint:
        raise RunError(f"{path} is not a sumo-rail checkpoint")
    if checkpoint["format"] != expected:
        raise RunError(f"checkpoint {path} has format {checkpoint['format']!r}; this sumo-rail reads {expected!r} "
                       f"here")
    return checkpoint


@contextmanager
def signals_deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM until the block ends, then stop (KeyboardInterrupt), so one iteration's files stay
    consistent. (Python-level handlers: a signal mask would not do, the kernel hands it to another thread.)"""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    previous = {number: signal.signal(number, lambda caught, frame: received.append(caught))
                for number in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
    if received:
        raise KeyboardInterrupt


class StopRequest:
    """Whether a stop was asked for: a plain flag, which a signal handler can set while another signal interrupts it
    (a `threading.Event` takes a lock in `set`, so a second Ctrl-C arriving inside the first one's handler would
    deadlock the main thread)."""

    def __init__(self) -> None:
        self.requested = False

    def set(self) -> None:
        self.requested = True

    def is_set(self) -> bool:
        return self.requested


@contextmanager
def signals_ignored() -> Iterator[None]:
    """Ignore SIGINT and SIGTERM within the block (main thread only; handlers restored after): for closing what must
    close whole, such as a run's environment processes after a Ctrl-C already stopped the run."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {number: signal.signal(number, signal.SIG_IGN) for number in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


@contextmanager
def stop_requests() -> Iterator[StopRequest]:
    """A flag that SIGINT and SIGTERM set instead of interrupting (main thread only; handlers restored after): the
    run stops at the end of its current step."""
    stop = StopRequest()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    previous = {number: signal.signal(number, lambda caught, frame: stop.set())
                for number in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
