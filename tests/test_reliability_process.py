"""The command as a process: one command per output, and Ctrl-C and SIGTERM from its first moment."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

from click.testing import CliRunner
from reliability import stopped_after
from sumo_rail_cli.main import cli
from sumo_rail_cli.output_lock import lock_path

SMALL = ["--set", "scenario.length_m=1500", "--set", "scenario.warmup_s=120", "--set", "scenario.snapshots=3",
         "--set", "scenario.snapshot_interval_s=10", "--set", "env.ego_start_max_m=500"]


def test_an_output_another_command_writes_is_one_sentence_and_a_dead_holders_lock_is_taken_over(tmp_path):
    out = tmp_path / "demos.parquet"
    holder = subprocess.Popen(["sleep", "600"])
    try:
        lock_path(out).write_text(f"{holder.pid}\n")
        result = CliRunner().invoke(cli, ["record-expert", *SMALL, "--episodes", "1", "--out", str(out)])
        assert result.exit_code == 1 and f"pid {holder.pid}" in result.output and str(out) in result.output
        assert "Traceback" not in result.output and not out.exists()
        assert lock_path(out).read_text() == f"{holder.pid}\n"  # the holder's lock is left alone
    finally:
        holder.kill()
        holder.wait()
    # its holder gone (killed), the lock is taken over, and released however the command ends (here: an error)
    missing = tmp_path / "missing.npz"
    result = CliRunner().invoke(cli, ["record-expert", *SMALL, "--episodes", "1", "--expert", str(missing),
                                      "--out", str(out)])
    assert result.exit_code != 0 and str(missing) in result.output and "pid" not in result.output, result.output
    assert sorted(tmp_path.iterdir()) == []


def test_a_report_folder_another_command_writes_is_one_sentence(tmp_path):
    out, metrics = tmp_path / "report", tmp_path / "metrics.parquet"
    metrics.write_bytes(b"not read: the lock is checked first")
    holder = subprocess.Popen(["sleep", "600"])
    try:
        lock_path(out).write_text(f"{holder.pid}\n")
        result = CliRunner().invoke(cli, ["report", str(metrics), "--out", str(out)])
        assert result.exit_code == 1 and f"pid {holder.pid}" in result.output and "Traceback" not in result.output
        assert not out.exists()
    finally:
        holder.kill()
        holder.wait()


def test_a_video_folder_another_command_writes_is_one_sentence(tmp_path):
    """--video is an output as --out is: two evaluations filming into one folder at once mixed (or replaced) each
    other's videos; the second is refused before any work, naming the option."""
    videos, out = tmp_path / "videos", tmp_path / "metrics.parquet"
    holder = subprocess.Popen(["sleep", "600"])
    try:
        lock_path(videos).write_text(f"{holder.pid}\n")
        result = CliRunner().invoke(cli, ["evaluate", *SMALL, "--policy", "keep", "--episodes", "1", "--video",
                                          str(videos), "--out", str(out)])
        assert result.exit_code == 1 and f"pid {holder.pid}" in result.output and "--video" in result.output
        assert "Traceback" not in result.output and not out.exists() and not videos.exists()
    finally:
        holder.kill()
        holder.wait()


def _caught(pid: int, number: int) -> bool:
    """Whether process `pid` has a handler for signal `number` (/proc's SigCgt mask)."""
    status = Path(f"/proc/{pid}/status").read_text()
    mask = int(next(line.split()[1] for line in status.splitlines() if line.startswith("SigCgt:")), 16)
    return bool(mask >> (number - 1) & 1)


def _signal_once_handled(command: list[str], number: int, ignore_sigint: bool) -> str:
    """Run `sumo-rail COMMAND`, send it signal `number` as soon as it handles it (found with the process stopped),
    checking that numpy is not loaded yet then (the handlers come before the slow imports); its output."""
    def start() -> None:
        if ignore_sigint:  # as a shell script's background job starts
            signal.signal(signal.SIGINT, signal.SIG_IGN)

    process = subprocess.Popen([sys.executable, "-m", "sumo_rail_cli", *command], stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True, preexec_fn=start)
    try:
        while True:
            process.send_signal(signal.SIGSTOP)
            try:
                if _caught(process.pid, number):
                    maps = Path(f"/proc/{process.pid}/maps").read_text()
                    assert "_multiarray_umath" not in maps, "the signal is handled only after numpy is loaded"
                    process.send_signal(number)
                    break
            finally:
                process.send_signal(signal.SIGCONT)
            assert process.poll() is None, process.stdout.read()
            time.sleep(0.001)
        output, _ = process.communicate(timeout=300)
        assert process.returncode == 1, output
        return output
    finally:
        process.kill()
        process.wait()


def test_a_ctrl_c_while_starting_from_a_script_is_one_sentence(tmp_path):
    output = _signal_once_handled(["record-expert", *SMALL, "--out", str(tmp_path / "d.parquet")], signal.SIGINT,
                                  ignore_sigint=True)
    assert "interrupted before any work began" in output and "Traceback" not in output, output
    assert list(tmp_path.iterdir()) == []


def test_a_sigterm_while_gail_starts_is_one_sentence(tmp_path):
    output = _signal_once_handled(["gail", *SMALL, "--demos", str(tmp_path / "d.parquet"), "--out",
                                   str(tmp_path / "run")], signal.SIGTERM, ignore_sigint=False)
    assert "interrupted before any work began" in output and "Traceback" not in output, output
    assert list(tmp_path.iterdir()) == []


def test_a_stop_after_the_imports_and_before_the_command_is_one_sentence():
    """The window between `sumo-rail`'s imports and its command (click's parsing, --version): a signal there is the
    one sentence, as in the imports and in the command's checks."""
    script = ("import os, signal\nfrom sumo_rail_cli.main import cli\nos.kill(os.getpid(), signal.SIGTERM)\n"
              "cli(['--version'], prog_name='sumo-rail')\n")
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert result.returncode == 1 and result.stdout == "", result
    assert result.stderr == "Error: interrupted before any work began; nothing was written\n", result.stderr


def test_evaluate_with_one_worker_runs_in_this_process(monkeypatch):
    from sumo_rail.runners.backends import ProcessPoolBackend

    def no_worker(self: ProcessPoolBackend) -> None:
        raise AssertionError("a worker process was started")

    monkeypatch.setattr(ProcessPoolBackend, "_start_worker", no_worker)
    result = CliRunner().invoke(cli, ["evaluate", *SMALL, "--policy", "keep", "--episodes", "1", "--workers", "1"])
    assert result.exit_code == 0, result.output
    result = CliRunner().invoke(cli, ["evaluate", *SMALL, "--policy", "keep", "--episodes", "1", "--workers", "2"])
    assert result.exit_code != 0  # two workers are processes


def test_a_simulation_that_fell_back_to_traci_ends_quietly_with_its_process():
    """A second env in one process runs over traci (as Gymnasium's and PettingZoo's checkers make one): left open
    when the process ends, its SUMO process is closed, so SUMO reports no error where none happened."""
    script = """
import warnings
from sumo_rail.config import Config
from sumo_rail.sim.env import HighwayEnv
warnings.simplefilter("ignore")
config = Config.from_dict({"scenario": {"length_m": 1500.0, "warmup_s": 120.0, "snapshots": 3,
                                        "snapshot_interval_s": 10.0}, "env": {"ego_start_max_m": 500.0}})
first, second = HighwayEnv(config), HighwayEnv(config)
first.reset(seed=1)
second.reset(seed=1)
print("ran", first.simulation.transport, second.simulation.transport)
"""
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0 and result.stdout.split() == ["ran", "libsumo", "traci"], result.stderr
    assert "Error" not in result.stderr and "Quitting" not in result.stderr, result.stderr


def test_a_stop_in_a_commands_checks_is_one_sentence(tmp_path, monkeypatch):
    from sumo_rail_cli import commands

    def stopped(*args: object) -> None:
        raise KeyboardInterrupt  # what the handlers raise on Ctrl-C or SIGTERM

    monkeypatch.setattr(commands, "check_egos", stopped)
    out = tmp_path / "d.parquet"
    result = CliRunner().invoke(cli, ["record-expert", *SMALL, "--out", str(out)])
    assert result.exit_code == 1, result.output
    assert result.output == f"Error: interrupted; nothing was written to {out}\n", result.output
    assert list(tmp_path.iterdir()) == []  # the output's lock released too


def test_a_stop_after_daggers_last_round_says_its_run_folder_was_written_not_that_no_work_began(tmp_path, demos_path):
    """A Ctrl-C as the backend closes after the last round: the run folder is complete, and the sentence says so."""
    run = tmp_path / "run"
    result = stopped_after("sumo_rail.runners.backends:ProcessPoolBackend.close", signal.SIGINT,
                           ["dagger", *SMALL, "--demos", str(demos_path), "--rounds", "1", "--set",
                            "dagger.episodes_per_round=1", "--set", "bc.epochs=1", "--eval-every", "0", "--out",
                            str(run)], tmp_path)
    assert result.returncode == 1 and "Traceback" not in result.stderr, result.stderr
    assert result.stderr.splitlines()[-1] == f"Error: interrupted after the work was done; {run} was written"
    assert (run / "policy_latest.npz").is_file() and (run / "checkpoint.json").is_file()
