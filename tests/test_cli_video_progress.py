"""evaluate --video writes one MP4 per chosen episode and driver; progress output fits a terminal or a log."""

import io
import sys

import numpy as np
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from sumo_rail_cli.main import cli
from sumo_rail_cli.progress import PlainProgress, progress, start_at

from sumo_rail.runners.video import read_frames
from sumo_rail.sim.render import EGO

SMALL = ["--set", "scenario.length_m=1500", "--set", "scenario.warmup_s=120", "--set", "scenario.snapshots=3",
         "--set", "scenario.snapshot_interval_s=10", "--set", "env.ego_start_max_m=500"]


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


def test_evaluate_video_writes_an_mp4_per_chosen_episode_and_driver(tmp_path):
    videos, out = tmp_path / "videos", tmp_path / "metrics.parquet"
    result = invoke("evaluate", "--policy", "expert", "--policy", "keep", "--episodes", "3", "--seed", "5",
                    "--video", str(videos), "--video-episodes", "2", *SMALL, "--out", str(out))
    assert result.exit_code == 0, result.output
    metrics = pq.read_table(out).to_pandas()
    expected = {f"{policy.replace('expert', 'expert-normal')}_episode{row.episode:03d}_seed{row.seed}.mp4"
                for policy in ("expert", "keep") for row in metrics[metrics.policy == policy.replace(
                    "expert", "expert-normal")].itertuples() if row.episode < 2}
    assert {path.name for path in videos.iterdir()} == expected and len(expected) == 4
    first = metrics[(metrics.policy == "keep") & (metrics.episode == 0)].iloc[0]
    frames = read_frames(videos / f"keep_episode000_seed{first.seed}.mp4")
    assert len(frames) == first.steps + 1  # the reset, then one frame per decision
    middle = frames[len(frames) // 2].astype(int)
    near_ego = np.abs(middle - np.array(EGO)).sum(axis=2) < 60  # the red ego survives compression
    assert near_ego.sum() > 20

    again = invoke("evaluate", "--policy", "keep", "--episodes", "1", "--seed", "5", "--video", str(videos), *SMALL)
    assert again.exit_code == 2 and "--overwrite" in again.output and "Traceback" not in again.output


def test_video_options_are_checked_before_any_work(tmp_path, monkeypatch):
    assert invoke("evaluate", "--video-episodes", "2").exit_code == 2
    not_a_folder = tmp_path / "file.mp4"
    not_a_folder.write_text("x")
    result = invoke("evaluate", "--video", str(not_a_folder))
    assert result.exit_code == 2 and "is a file" in result.output
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # as if the extra were not installed
    result = invoke("evaluate", "--video", str(tmp_path / "v"))
    assert result.exit_code == 1 and "pip install 'sumo-rail[video]'" in result.output
    assert "Traceback" not in result.output and not (tmp_path / "v").exists()


def test_progress_off_a_terminal_is_plain_lines_without_carriage_returns(tmp_path):
    result = invoke("record-expert", "--episodes", "2", *SMALL, "--out", str(tmp_path / "demos.parquet"))
    assert result.exit_code == 0, result.output
    assert "\r" not in result.output
    assert "recording: 2/2 episodes (100%)" in result.output


def test_plain_progress_prints_at_most_every_interval_and_once_at_the_end():
    now = [0.0]
    stream = io.StringIO()
    bar = PlainProgress(10, "training", "iteration", stream, interval_s=5.0, clock=lambda: now[0])
    with bar:
        for _ in range(10):
            now[0] += 1.0
            bar.set_postfix(D_return="+0.100")
            bar.update()
        bar.write("a message")
    lines = stream.getvalue().splitlines()
    assert lines[0].startswith("training: 5/10 iterations (50%), 1.00 iteration/s, elapsed 5 s, D_return=+0.100")
    assert lines[1].startswith("training: 10/10 iterations (100%)")
    assert lines[2] == "a message" and len(lines) == 3


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.mark.parametrize(("stream", "live"), [(Terminal(), True), (io.StringIO(), False)])
def test_progress_is_a_live_bar_only_on_a_terminal(stream, live):
    bar = progress(3, "evaluating", stream=stream)
    with bar:
        bar.update()
    assert isinstance(bar, PlainProgress) is not live
    assert ("\r" in stream.getvalue()) is live


def test_the_last_progress_line_is_at_100_percent_for_resumed_runs_and_egos_and_one_is_singular(tmp_path):
    demos = tmp_path / "demos.parquet"
    result = invoke("record-expert", *SMALL, "--episodes", "3", "--egos", "2", "--out", str(demos))
    assert result.exit_code == 0 and "recording: 3/3 episodes (100%)" in result.output, result.output
    dagger = ("dagger", *SMALL, "--demos", str(demos), "--rounds", "1", "--set", "dagger.episodes_per_round=1", "--set",
              "bc.epochs=1", "--eval-every", "0", "--out", str(tmp_path / "dagger"))
    result = invoke(*dagger)
    assert result.exit_code == 0 and "DAgger: 1 round; policy in" in result.output, result.output
    result = invoke(*dagger, "--resume")  # nothing left to do
    assert result.exit_code == 0 and "DAgger: 2/2 rounds (100%)" in result.output, result.output
    train = ("train", *SMALL, "--demos", str(demos), "--set", "rail.directions=2", "--set", "bc.epochs=1",
             "--eval-every", "0",
             "--out", str(tmp_path / "train"))
    result = invoke(*train, "--iterations", "1")
    assert result.exit_code == 0 and "trained 1 iteration; policies in" in result.output, result.output
    result = invoke(*train, "--iterations", "2", "--resume")
    assert result.exit_code == 0 and "training: 2/2 iterations (100%)" in result.output, result.output


def test_a_resumed_runs_progress_counts_from_where_it_stopped():
    now = [0.0]
    stream = io.StringIO()
    bar = PlainProgress(10, "training", "iteration", stream, interval_s=5.0, clock=lambda: now[0])
    with bar:
        now[0] += 100.0  # reading the checkpoint
        start_at(bar, 6)
        for _ in range(4):
            now[0] += 2.0
            bar.update()
    lines = stream.getvalue().splitlines()
    assert lines[0].startswith("training: 9/10 iterations (90%), 0.50 iteration/s, elapsed 6 s")  # this run's three
    assert lines[1].startswith("training: 10/10 iterations (100%), 0.50 iteration/s, elapsed 8 s")
    live = progress(10, "training", unit="iteration", stream=Terminal())
    with live:
        start_at(live, 6)
        assert (live.n, live.initial) == (6, 6)  # tqdm's rate counts from `initial`
        live.update()
    assert "7/10" in live.fp.getvalue()


def test_a_resumed_gail_or_ppo_rate_counts_its_own_timesteps_as_train_does():
    from sumo_rail_cli.running import sb3_progress

    now = [0.0]
    stream = io.StringIO()
    bar = PlainProgress(1000, "PPO", "timestep", stream, interval_s=5.0, clock=lambda: now[0])
    with bar:
        now[0] += 10.0  # the first new update: 100 timesteps after 5 updates done before the resume
        sb3_progress(bar, {"iteration": 5}, 100)
        now[0] += 10.0
        sb3_progress(bar, {"iteration": 6}, 100)
    lines = stream.getvalue().splitlines()
    assert lines[0].startswith("PPO: 600/1000 timesteps (60%), 10.00 timestep/s, elapsed 10 s"), lines
    assert lines[1].startswith("PPO: 700/1000 timesteps (70%), 10.00 timestep/s, elapsed 20 s"), lines
    live = progress(1000, "GAIL", unit="timestep", stream=Terminal())
    with live:
        sb3_progress(live, {"iteration": 5}, 100)
        assert (live.n, live.initial) == (600, 500)  # tqdm's rate counts from `initial`


def fake_train(done: int, interrupt: bool = False):
    """In place of `trainer.train`: a run in a new folder (run.json only) that is resumed from `done` iterations and
    then interrupted or runs one more iteration."""
    from types import SimpleNamespace

    from sumo_rail.learning.run_folder import start_run_folder

    def train(folder, settings, config, iterations, backend, resume, validation, on_bc, on_iteration, on_start,
              in_seats=None):
        if not folder.exists():
            start_run_folder(folder, {"settings": {}, "config": {}})
        on_start(done)
        if interrupt:
            raise KeyboardInterrupt
        on_iteration({"iteration": done, "env_steps": 10, "wall_time_s": 1.0, "return_mean": 0.0,
                      "eval_average_speed_kmh": None})
        return SimpleNamespace(iteration=done + 1)

    return train


def test_a_resumed_train_counts_from_its_resumed_iteration(tmp_path, monkeypatch):
    from sumo_rail_cli import commands

    from sumo_rail.learning.rail import trainer

    started: list[tuple[int, int]] = []
    monkeypatch.setattr(trainer, "train", fake_train(3))
    monkeypatch.setattr(commands, "start_at", lambda bar, done: (started.append((bar.n, done)), start_at(bar, done)))
    result = invoke("train", "--demos", str(tmp_path / "demos.parquet"), "--iterations", "4", "--out",
                    str(tmp_path / "run"))
    assert result.exit_code == 0, result.output
    assert started == [(0, 3)] and "training: 4/4 iterations (100%)" in result.output


def test_ctrl_c_before_trains_first_iteration_does_not_offer_resume(tmp_path, monkeypatch):
    from sumo_rail.learning.rail import trainer

    run = tmp_path / "run"
    monkeypatch.setattr(trainer, "train", fake_train(0, interrupt=True))
    result = invoke("train", "--demos", str(tmp_path / "demos.parquet"), "--out", str(run))
    assert result.exit_code == 1 and "Traceback" not in result.output, result.output
    assert f"nothing to resume: remove {run} and run the command again" in result.output
    assert "--resume" not in result.output
    (run / "checkpoint.pt").write_bytes(b"an iteration saved")
    result = invoke("train", "--demos", str(tmp_path / "demos.parquet"), "--out", str(run), "--resume")
    assert result.exit_code == 1 and f"{run} keeps its last complete iteration, continue with --resume" in result.output
