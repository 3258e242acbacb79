"""export-minari: a Minari dataset with the demonstrations' observations, actions and episode boundaries."""

import os
import subprocess
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from sumo_rail_cli.main import cli
from sumo_rail_cli.output_lock import lock_path

SMALL = ["--set", "scenario.length_m=1500", "--set", "scenario.warmup_s=120", "--set", "scenario.snapshots=3",
         "--set", "scenario.snapshot_interval_s=10", "--set", "env.ego_start_max_m=500"]


@pytest.fixture(scope="module")
def demos(tmp_path_factory):
    path = tmp_path_factory.mktemp("demos") / "expert.parquet"
    result = CliRunner().invoke(cli, ["record-expert", "--episodes", "3", "--seed", "4", *SMALL, "--out", str(path)])
    assert result.exit_code == 0, result.output
    return path


def test_export_loads_with_minari_with_the_same_observations_actions_and_episodes(demos, tmp_path, monkeypatch):
    minari = pytest.importorskip("minari", reason="the Minari export is the package's optional extra [minari]")
    root = tmp_path / "minari"
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(root))  # never the user's ~/.minari
    result = CliRunner().invoke(cli, ["export-minari", str(demos), "--name", "sumo-rail/expert-v0"])
    assert result.exit_code == 0, result.output
    table = pq.read_table(demos).to_pandas()
    dataset = minari.load_dataset("sumo-rail/expert-v0")
    assert dataset.total_episodes == table.episode.nunique() == 3
    assert dataset.total_steps == len(table)
    for episode, (_, rows) in zip(dataset.iterate_episodes(), table.groupby("episode"), strict=True):
        rows = rows.sort_values("step")
        observations = np.stack(rows.observation.to_numpy())
        assert len(episode.actions) == len(rows) and len(episode.observations) == len(rows) + 1
        assert np.array_equal(episode.observations[:-1], observations)
        assert np.array_equal(episode.actions, rows.action.to_numpy())
        assert np.allclose(episode.rewards, rows.reward.to_numpy())
        assert episode.terminations[-1] == rows.terminated.iloc[0] and not episode.terminations[:-1].any()
        assert episode.truncations[-1] == rows.truncated.iloc[0] and not episode.truncations[:-1].any()
    env = dataset.recover_environment()  # the recording's config travels with the dataset
    assert env.unwrapped.config.scenario.length_m == 1500.0
    env.close()

    again = CliRunner().invoke(cli, ["export-minari", str(demos), "--name", "sumo-rail/expert-v0"])
    assert again.exit_code == 1 and "--overwrite" in again.output and "Traceback" not in again.output
    replaced = CliRunner().invoke(cli, ["export-minari", str(demos), "--name", "sumo-rail/expert-v0", "--root",
                                        str(root), "--overwrite"])
    assert replaced.exit_code == 0, replaced.output
    assert [path.name for path in root.iterdir() if path.name.startswith(".")] == []  # no scratch folder left


def test_a_relative_datasets_folder_is_where_the_dataset_goes(demos, tmp_path, monkeypatch):
    """--root or MINARI_DATASETS_PATH relative to the working folder (Minari itself failed with a traceback)."""
    minari = pytest.importorskip("minari", reason="the Minari export is the package's optional extra [minari]")
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(cli, ["export-minari", str(demos), "--name", "sumo-rail/given-v0", "--root", "given"])
    assert result.exit_code == 0, result.output
    monkeypatch.setenv("MINARI_DATASETS_PATH", "from_environment")
    result = CliRunner().invoke(cli, ["export-minari", str(demos), "--name", "sumo-rail/expert-v0"])
    assert result.exit_code == 0, result.output
    assert minari.load_dataset("sumo-rail/expert-v0").total_episodes == 3
    monkeypatch.setenv("MINARI_DATASETS_PATH", "given")
    assert minari.load_dataset("sumo-rail/given-v0").total_episodes == 3


def test_bad_inputs_are_one_sentence_errors(demos, tmp_path):
    result = CliRunner().invoke(cli, ["export-minari", str(demos), "--name", "not a valid id!", "--root",
                                      str(tmp_path)])
    assert result.exit_code == 1 and "is not a Minari dataset id" in result.output
    not_demos = tmp_path / "x.parquet"
    not_demos.write_bytes(b"nope")
    result = CliRunner().invoke(cli, ["export-minari", str(not_demos), "--name", "a-v0", "--root", str(tmp_path)])
    assert result.exit_code == 1 and "Traceback" not in result.output


def test_missing_minari_names_the_extra_to_install(demos, tmp_path, monkeypatch):
    monkeypatch.setitem(__import__("sys").modules, "minari", None)
    result = CliRunner().invoke(cli, ["export-minari", str(demos), "--name", "a-v0", "--root", str(tmp_path)])
    assert result.exit_code == 1 and "pip install 'sumo-rail[minari]'" in result.output


def test_a_dataset_another_command_writes_is_one_sentence_and_left_alone(demos, tmp_path):
    """Two exports of one dataset id at once: the second says who holds it (exit 1) and writes nothing."""
    pytest.importorskip("minari", reason="the Minari export is the package's optional extra [minari]")
    target = tmp_path / "sumo-rail" / "expert-v0"
    target.parent.mkdir()
    holder = subprocess.Popen(["sleep", "600"])
    try:
        lock_path(target).write_text(f"{holder.pid}\n")
        result = CliRunner().invoke(cli, ["export-minari", str(demos), "--name", "sumo-rail/expert-v0", "--root",
                                          str(tmp_path)])
        assert result.exit_code == 1 and f"pid {holder.pid}" in result.output and "Traceback" not in result.output
        assert not target.exists() and lock_path(target).read_text() == f"{holder.pid}\n"
    finally:
        holder.kill()
        holder.wait()
    result = CliRunner().invoke(cli, ["export-minari", str(demos), "--name", "sumo-rail/expert-v0", "--root",
                                      str(tmp_path)])
    assert result.exit_code == 0 and target.is_dir() and not lock_path(target).exists(), result.output


def test_a_datasets_folder_that_cannot_be_written_is_one_sentence(demos, tmp_path):
    """A read-only --root (for root, which writes anywhere else, sysfs) is said before any episode is replayed."""
    pytest.importorskip("minari", reason="the Minari export is the package's optional extra [minari]")
    root = Path("/sys") if os.geteuid() == 0 else tmp_path / "read_only"
    if root != Path("/sys"):
        root.mkdir()
        root.chmod(0o555)
    result = CliRunner().invoke(cli, ["export-minari", str(demos), "--name", "sumo-rail/expert-v0", "--root",
                                      str(root)])
    assert result.exit_code == 1 and f"cannot write into the Minari datasets folder {root}" in result.output, \
        result.output
    assert "Traceback" not in result.output and not (root / "sumo-rail").exists()


def _rewritten(demos: Path, out: Path, column: str, values) -> Path:
    """`demos` with `column` replaced by the arrow array `values`, its metadata kept."""
    table = pq.read_table(demos)
    table = table.set_column(table.schema.get_field_index(column), column, values)
    pq.write_table(table.replace_schema_metadata(pq.read_schema(demos).metadata), out)
    return out


def test_damaged_demonstrations_are_one_sentence_and_nothing_is_exported(demos, tmp_path):
    """A demonstrations file rewritten by another tool (pandas makes the observation a list of any length), or with a
    non-finite observation or an action of no interface, is said as train says it, exit 1, no dataset written
    (was an AttributeError traceback, or a replay of nonsense)."""
    import pyarrow as pa

    table = pq.read_table(demos)
    observations = table.column("observation").combine_chunks()
    size = observations.type.list_size
    flat = observations.flatten().to_numpy().copy()
    flat[size * 2] = np.nan
    actions = table.column("action").to_numpy().copy()
    actions[1] = 9
    damaged = {
        "has no fixed-size observation column": _rewritten(demos, tmp_path / "lists.parquet", "observation",
                                                           observations.cast(pa.list_(pa.float32()))),
        "has non-finite observations": _rewritten(demos, tmp_path / "nan.parquet", "observation",
                                                  pa.FixedSizeListArray.from_arrays(pa.array(flat), size)),
        "has actions outside 0..4": _rewritten(demos, tmp_path / "actions.parquet", "action",
                                               pa.array(actions, type=table.schema.field("action").type)),
    }
    for sentence, path in damaged.items():
        result = CliRunner().invoke(cli, ["export-minari", str(path), "--name", "sumo-rail/d-v0", "--root",
                                          str(tmp_path / "minari")])
        assert result.exit_code == 1 and f"{path} {sentence}" in result.output, result.output
        assert "Traceback" not in result.output and not (tmp_path / "minari").exists()
