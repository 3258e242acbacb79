"""experiments/grid.py: a spec's steps over its axes, finished outputs skipped, run folders resumed."""

from __future__ import annotations

import importlib.util
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("grid", ROOT / "experiments" / "grid.py")
grid = importlib.util.module_from_spec(_spec)
sys.modules["grid"] = grid  # dataclasses look their module up by name
_spec.loader.exec_module(grid)

WRITER = "import pathlib, sys; pathlib.Path(sys.argv[1]).write_text(' '.join(sys.argv[2:]))"
FOLDER_RUN = ("import pathlib, sys; folder = pathlib.Path(sys.argv[1]); folder.mkdir(exist_ok=True); "
              "(folder / 'calls').open('a').write(' '.join(sys.argv[2:]) + chr(10))")


def write_spec(folder: Path) -> Path:
    spec = folder / "spec.toml"
    spec.write_text(f"""
root = "{folder / 'out'}"
[axes]
seed = [0, 1]
road = ["straight", "exit"]
[[step]]
out = "{{root}}/file_{{road}}_s{{seed}}.txt"
command = ["python", "-c", "{WRITER}", "{{out}}", "{{road}}", "{{seed}}"]
[[step]]
out = "{{root}}/run_s{{seed}}"
command = ["python", "-c", "{FOLDER_RUN}", "{{out}}", "seed", "{{seed}}"]
resume = true
""")
    return spec


def test_each_step_runs_once_per_combination_of_the_axes_it_names(tmp_path):
    result = CliRunner().invoke(grid.main, [str(write_spec(tmp_path))])
    assert result.exit_code == 0, result.output
    out = tmp_path / "out"
    assert sorted(path.name for path in out.iterdir()) == ["file_exit_s0.txt", "file_exit_s1.txt",
                                                             "file_straight_s0.txt", "file_straight_s1.txt",
                                                             "run_s0", "run_s1"]
    assert (out / "file_exit_s1.txt").read_text() == "exit 1"
    assert (out / "run_s1" / "calls").read_text() == "seed 1\n"


def test_a_second_run_skips_finished_files_and_resumes_run_folders(tmp_path):
    spec = write_spec(tmp_path)
    CliRunner().invoke(grid.main, [str(spec)])
    (tmp_path / "out" / "file_exit_s0.txt").write_text("kept")
    result = CliRunner().invoke(grid.main, [str(spec)])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "out" / "file_exit_s0.txt").read_text() == "kept"
    assert (tmp_path / "out" / "run_s0" / "calls").read_text() == "seed 0\nseed 0 --resume\n"


def test_an_axis_can_be_narrowed_from_the_command_line(tmp_path):
    result = CliRunner().invoke(grid.main, [str(write_spec(tmp_path)), "--axis", "seed=1", "--only", "exit"])
    assert result.exit_code == 0, result.output
    assert sorted(path.name for path in (tmp_path / "out").iterdir()) == ["file_exit_s1.txt"]


def test_a_failed_step_stops_the_grid_in_one_sentence(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text('[[step]]\nout = "x"\ncommand = ["python", "-c", "raise SystemExit(3)"]\n'
                    '[[step]]\nout = "y"\ncommand = ["python", "-c", "print(1)"]\n')
    result = CliRunner().invoke(grid.main, [str(spec)])
    assert result.exit_code == 1
    assert "step x failed (exit 3)" in result.output
    assert "[2/2]" not in result.output


def test_an_unknown_placeholder_or_axis_is_a_usage_error(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text('[axes]\nseed = [0]\n[[step]]\nout = "{root}/{method}"\ncommand = ["python"]\n')
    result = CliRunner().invoke(grid.main, [str(spec)])
    assert result.exit_code == 2 and "{method} is neither an axis" in result.output
    result = CliRunner().invoke(grid.main, [str(spec), "--axis", "road=exit"])
    assert result.exit_code == 2 and "no such axis" in result.output


def test_every_committed_spec_expands_to_commands_of_this_project(tmp_path):
    for spec_path in sorted((ROOT / "experiments" / "specs").glob("*.toml")):
        steps = grid.expand(grid.read_spec(spec_path), spec_path, {})
        assert steps, spec_path
        for step in steps:
            assert step.copy is not None or step.command[0] in ("sumo-rail", "python"), (spec_path, step.out)
            scripts = [part for part in step.command if part.startswith("experiments/")]
            assert all((ROOT / script).is_file() for script in scripts), (spec_path, scripts)


def test_each_table_axes_stdout_read_and_copy(tmp_path):
    spec = tmp_path / "spec.toml"
    echo = "import sys; print(' '.join(sys.argv[1:]))"
    spec.write_text(f"""
root = "{tmp_path / 'out'}"
[axes]
seed = [0, 1]
setting = [{{name = "plain", args = []}}, {{name = "flip", args = ["--set", "rail.flip_rate=0.2"]}}]
[[step]]
out = "{{root}}/budget_s{{seed}}.txt"
stdout = "{{out}}"
command = ["python", "-c", "{echo}", "{{seed}}00"]
[[step]]
out = "{{root}}/copy_s{{seed}}.txt"
copy = "{{root}}/budget_s{{seed}}.txt"
[[step]]
out = "{{root}}/run_{{setting}}_s{{seed}}.txt"
stdout = "{{out}}"
read = {{budget = "{{root}}/copy_s{{seed}}.txt"}}
command = ["python", "-c", "{echo}", "{{setting.args}}", "--timesteps", "{{budget}}"]
[[step]]
out = "{{root}}/evaluate.txt"
stdout = "{{out}}"
command = ["python", "-c", "{echo}", {{each = "seed", args = ["--policy", "p{{seed}}"]}}]
""")
    result = CliRunner().invoke(grid.main, [str(spec)])
    assert result.exit_code == 0, result.output
    out = tmp_path / "out"
    assert (out / "copy_s1.txt").read_text() == "100\n"
    assert (out / "run_flip_s1.txt").read_text() == "--set rail.flip_rate=0.2 --timesteps 100\n"
    assert (out / "run_plain_s0.txt").read_text() == "--timesteps 000\n"
    assert (out / "evaluate.txt").read_text() == "--policy p0 --policy p1\n"
    assert not list(out.glob("*.partial"))


def test_a_failed_step_s_printed_output_is_not_kept(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text(f'[[step]]\nout = "{tmp_path}/t.txt"\nstdout = "{tmp_path}/t.txt"\n'
                    'command = ["python", "-c", "print(1); raise SystemExit(2)"]\n')
    assert CliRunner().invoke(grid.main, [str(spec)]).exit_code == 1
    assert not (tmp_path / "t.txt").exists()


def test_a_value_kept_out_by_default_runs_when_named_and_root_can_move(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text(f'root = "{tmp_path}/spec_root"\n[axes]\n'
                    'option = [{name = "plain", args = []}, {name = "extra", args = ["-x"], default = false}]\n'
                    '[[step]]\nout = "{root}/{option}.txt"\nstdout = "{out}"\n'
                    'command = ["python", "-c", "print(1)"]\n')
    assert CliRunner().invoke(grid.main, [str(spec)]).exit_code == 0
    assert sorted(path.name for path in (tmp_path / "spec_root").iterdir()) == ["plain.txt"]
    moved = tmp_path / "moved"
    result = CliRunner().invoke(grid.main, [str(spec), "--axis", "option=extra", "--root", str(moved)])
    assert result.exit_code == 0, result.output
    assert sorted(path.name for path in moved.iterdir()) == ["extra.txt"]
    result = CliRunner().invoke(grid.main, [str(spec), "--axis", "option=other"])
    assert result.exit_code == 2 and "other is not one of plain, extra" in result.output


SLEEPER = ("import os, pathlib, signal, sys, time; folder = pathlib.Path(sys.argv[1]); "
           "signal.signal(signal.SIGTERM, lambda number, frame: sys.exit((folder / 'got').write_text('SIGTERM'))); "
           "signal.signal(signal.SIGINT, lambda number, frame: sys.exit((folder / 'got').write_text('SIGINT'))); "
           "(folder / 'pid').write_text(str(os.getpid())); time.sleep(60)")


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


@pytest.mark.parametrize("stop", [signal.SIGTERM, signal.SIGINT])
def test_a_stopped_grid_stops_its_step_as_the_step_stops_and_says_so(tmp_path, stop):
    """SIGTERM (a scheduler, `kill`) or Ctrl-C sent to the grid alone reaches the step's command, which stops as it
    does on its own (a sumo-rail command keeps what it can); the grid waits for it, so no step is left running
    (holding its output for a rerun), and ends in one sentence naming the step (exit 1)."""
    spec = tmp_path / "spec.toml"
    spec.write_text(f'root = "{tmp_path}"\n[[step]]\nout = "{{root}}/sleep.txt"\n'
                    f'command = ["python", "-c", "{SLEEPER}", "{{root}}"]\n')
    grid_process = subprocess.Popen([sys.executable, str(ROOT / "experiments" / "grid.py"), str(spec)],
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    pid = None
    try:
        for _ in range(400):
            if (tmp_path / "pid").is_file() and (tmp_path / "pid").read_text():
                pid = int((tmp_path / "pid").read_text())
                break
            time.sleep(0.05)
        assert pid is not None, grid_process.communicate(timeout=5)
        grid_process.send_signal(stop)
        _, printed = grid_process.communicate(timeout=30)
        assert grid_process.returncode == 1, printed
        assert (tmp_path / "got").read_text() == stop.name  # the step was told, as Ctrl-C tells it
        assert not alive(pid)
        errors = [line for line in printed.splitlines() if line.startswith("Error:")]
        assert errors == [f"Error: interrupted by {stop.name} at {tmp_path / 'sleep.txt'}, whose command was "
                          f"stopped; run the same command again to go on"], printed
        assert "Traceback" not in printed
    finally:
        if grid_process.poll() is None:
            grid_process.kill()
        if pid is not None and alive(pid):
            os.kill(pid, signal.SIGKILL)


def test_a_command_that_is_a_string_is_refused_naming_the_step(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text(f'root = "{tmp_path}"\n[[step]]\nout = "{{root}}/a.txt"\ncommand = ["python", "-c", "print(1)"]\n'
                    f'[[step]]\nout = "{{root}}/b.txt"\ncommand = "python -c print(2)"\n')
    result = CliRunner().invoke(grid.main, [str(spec)])
    assert result.exit_code == 2, result.output
    assert f"{spec} step 2: command must be a list of words" in result.output, result.output
    assert not (tmp_path / "a.txt").exists()


def test_two_steps_with_one_out_are_refused_before_anything_runs(tmp_path):
    """A second step writing the first's output would never run while the grid reported both done; so would the
    expansions of one step whose out does not name an axis its command does."""
    spec = tmp_path / "spec.toml"
    printing = 'stdout = "{out}"\ncommand = ["python", "-c", "print(1)"]\n'
    spec.write_text(f'root = "{tmp_path}"\n[axes]\nseed = [0, 1]\n[[step]]\nout = "{{root}}/first.txt"\n{printing}'
                    f'[[step]]\nout = "{{root}}/table.txt"\n{printing}[[step]]\nout = "{{root}}/table.txt"\n{printing}')
    result = CliRunner().invoke(grid.main, [str(spec)])
    assert result.exit_code == 2, result.output
    assert (f"{spec} step 2 and {spec} step 3 both write {tmp_path / 'table.txt'}" in result.output), result.output
    assert sorted(path.name for path in tmp_path.iterdir()) == ["spec.toml"]
    spec.write_text(f'root = "{tmp_path}"\n[axes]\nseed = [0, 1]\n'
                    f'[[step]]\nout = "{{root}}/run.txt"\ncommand = ["python", "-c", "print(1)", "{{seed}}"]\n')
    result = CliRunner().invoke(grid.main, [str(spec)])
    assert result.exit_code == 2, result.output
    assert f"{spec} step 1 (seed=0) and {spec} step 1 (seed=1) both write {tmp_path / 'run.txt'}" in result.output
    assert sorted(path.name for path in tmp_path.iterdir()) == ["spec.toml"]


def test_a_step_that_cannot_start_is_one_sentence_naming_it(tmp_path):
    """A program that is not there, a copy of a file that is not there."""
    spec = tmp_path / "spec.toml"
    spec.write_text(f'root = "{tmp_path}"\n[[step]]\nout = "{{root}}/a.txt"\ncommand = ["sumo-rial", "train"]\n'
                    f'[[step]]\nout = "{{root}}/b.txt"\ncopy = "{{root}}/missing.txt"\n')
    for only, sentence in [("a.txt", f"step {tmp_path / 'a.txt'} cannot run: sumo-rial: No such file or directory"),
                           ("b.txt", f"step {tmp_path / 'b.txt'} cannot run: {tmp_path / 'missing.txt'}: No such file "
                                     f"or directory")]:
        result = CliRunner().invoke(grid.main, [str(spec), "--only", only])
        assert result.exit_code == 1, result.output
        assert [line for line in result.output.splitlines() if line.startswith("Error:")] == [f"Error: {sentence}"]
