"""experiments/grid.py: a spec's steps over its axes, finished outputs skipped, run folders resumed."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

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
