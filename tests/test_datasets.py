import os

import pyarrow as pa
import pytest

from sumo_rail import datasets
from sumo_rail.datasets import DatasetError, check_output_path, write_parquet


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
    locked.mkdir(mode=0o500)
    try:
        if os.geteuid() != 0:  # root can write anywhere
            with pytest.raises(DatasetError, match="not writable"):
                check_output_path(locked / "x.parquet", overwrite=False)
    finally:
        locked.chmod(0o700)
    assert existing.read_text() == "keep me"

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
