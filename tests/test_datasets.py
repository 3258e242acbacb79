import os
from collections.abc import Callable
from pathlib import Path

import pyarrow as pa
import pytest

from sumo_rail import datasets
from sumo_rail.datasets import DatasetError, check_output_folder, check_output_path, write_parquet


def test_output_path_checks(tmp_path):
    existing = tmp_path / "x.parquet"
    existing.write_text("keep me")
    with pytest.raises(DatasetError, match="--overwrite"):
        check_output_path(existing, overwrite=False)
    check_output_path(existing, overwrite=True)
    with pytest.raises(DatasetError, match="does not exist"):
        check_output_path(tmp_path / "missing" / "x.parquet", overwrite=False)
    with pytest.raises(DatasetError, match="folder"):
        check_output_path(tmp_path, overwrite=True)
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o555)
    try:
        assert "not writable" in check_as_a_user(locked)
    finally:
        locked.chmod(0o700)
    assert existing.read_text() == "keep me"


NOBODY = 65534
"""The user id and group id of `nobody`."""


def check_as_a_user(folder: Path, check: Callable[[Path], str] | None = None) -> str:
    """The message of `check` (default `output_path_message`) on a new path in `folder` ("" if it passes), as a user
    who is not root: root can write anywhere (CI runs as root), so there it is asked in a forked child that has become
    nobody."""
    check = check or output_path_message
    if os.geteuid() != 0:
        return check(folder / "x.parquet")
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: reports through the pipe and exits, never returning into pytest
        try:
            os.close(read_end)
            os.chdir(folder)  # tmp_path's parents may be closed to other users; `folder` is open to all
            os.setgroups([])
            os.setgid(NOBODY)
            os.setuid(NOBODY)
            message = check(Path("x.parquet"))
        except BaseException as error:
            message = f"cannot check as nobody: {error!r}"
        try:
            os.write(write_end, message.encode())
        finally:
            os._exit(0)
    os.close(write_end)
    with os.fdopen(read_end, "rb") as pipe:
        message = pipe.read().decode()
    os.waitpid(pid, 0)
    if message.startswith("cannot check as nobody"):
        pytest.skip(f"the not-writable check needs a user other than root, and {message}")
    return message


def output_folder_message(path: Path) -> str:
    try:
        check_output_folder(path / "run")
    except DatasetError as error:
        return str(error)
    return ""


def test_a_run_folder_that_cannot_be_made_or_written_is_refused_before_any_work(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o555)
    try:
        assert "cannot be written" in check_as_a_user(locked, output_folder_message)
    finally:
        locked.chmod(0o700)
    (tmp_path / "file").write_text("")
    with pytest.raises(DatasetError, match="is a file"):
        check_output_folder(tmp_path / "file")
    with pytest.raises(DatasetError, match=r"run folder .*run cannot be made: .*file is a file$"):
        check_output_folder(tmp_path / "file" / "run")
    check_output_folder(tmp_path / "new" / "run")  # made with its parents


def output_path_message(path: Path) -> str:
    try:
        check_output_path(path, overwrite=False)
    except DatasetError as error:
        return str(error)
    return ""


def test_interrupted_write_leaves_neither_file_nor_temporary(tmp_path, monkeypatch):
    path = tmp_path / "demos.parquet"
    path.write_text("previous")

    def interrupted(table, where, **kwargs):
        open(where, "wb").write(b"half")
        raise KeyboardInterrupt

    monkeypatch.setattr(datasets.pq, "write_table", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_parquet(pa.table({"a": [1, 2]}), path, {"kind": "test"})
    assert path.read_text() == "previous"
    assert [p.name for p in tmp_path.iterdir()] == ["demos.parquet"]
