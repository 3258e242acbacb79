"""Run an experiment as a grid of sumo-rail commands described by a small TOML spec (experiments/specs/*.toml).

A spec names its axes (methods, seeds, roads, settings: any name with a list of values) and its steps in order:

    root = "results/benchmark"                 # {root} in templates; relative to the current folder
    [axes]
    seed = [0, 1, 2]
    setting = [{name = "paper", args = []}, {name = "flip20", args = ["--set", "rail.flip_rate=0.2"]}]
    [[step]]
    out = "{root}/bc_{setting}_s{seed}"        # the step's output: a file or a run folder
    command = ["sumo-rail", "train", "{setting.args}", "--seed", "{seed}", "--out", "{out}"]
    resume = true                              # a run folder the command continues with --resume
    [[step]]
    out = "{root}/test.parquet"
    stdout = "{root}/test.txt"                 # the command's printed table, kept (written when it succeeds)
    command = ["sumo-rail", "evaluate", {each = "seed", args = ["--policy", "{root}/bc_paper_s{seed}/policy_bc.npz"]},
               "--out", "{out}"]

Each step runs once for every combination of the axes its templates name ({axis} is a value, or a table value's
name; {axis.key} a table value's key; "{axis.key}" alone in a command, for a list, is replaced by its items);
`{each = AXIS, args = [...]}` in a command repeats its args for every value of AXIS. `read = {name = "FILE"}`
makes {name} the last line of FILE, written by an earlier step; `copy = "FILE"` copies FILE to the output instead of
running a command; `always = true` runs a step every time (the tables made from the outputs before them). A table
value with `default = false` runs only when --axis names it. A command is a list of words; each step has its own
output (two steps with one `out` are refused before anything runs).

Run state is the outputs themselves, as the commands write them: a step whose output exists is finished (every
command writes its files atomically), except a `resume` step, whose existing, non-empty run folder is handed back to
the command with `--resume` (the command continues an interrupted run and returns at once from a finished one). So
the grid can be stopped (Ctrl-C or SIGTERM, which it passes on to the running step's command and waits for) and
started again at any point, with no marker files and no environment variables.
"sumo-rail" and "python" at the head of a command run in this interpreter's environment.

    python experiments/grid.py experiments/specs/SPEC.toml [--dry-run] [--root DIR] [--only TEXT] [--axis seed=0,1]
"""

from __future__ import annotations

import contextlib
import itertools
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tomllib
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import IO, Any

import click

PLACEHOLDER = re.compile(r"\{(\w+)(?:\.(\w+))?\}")
RUNNERS = {"sumo-rail": [sys.executable, "-m", "sumo_rail_cli"], "python": [sys.executable]}
STOP_WAIT_S = 60.0
"""How long a step's command may take to stop once the grid has passed it a Ctrl-C or SIGTERM [s]; then it is
killed."""


class Stopped(Exception):
    """The grid was asked to stop by the signal `number` (SIGINT: Ctrl-C, or SIGTERM)."""

    def __init__(self, number: int) -> None:
        super().__init__(signal.Signals(number).name)
        self.number = number


@contextlib.contextmanager
def stopped_by_signals() -> Iterator[None]:
    """Within it, Ctrl-C and SIGTERM raise `Stopped`: the first one stops the grid, those after it are ignored while
    the running step stops; the handlers before it are back after it."""
    previous = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}

    def stop(number: int, frame: FrameType | None) -> None:
        for each in previous:
            signal.signal(each, signal.SIG_IGN)
        raise Stopped(number)
    for number in previous:
        signal.signal(number, stop)
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def run_command(argv: list[str], stdout: IO[str] | None = None) -> int:
    """Run `argv` to its end and return its exit code. When the grid is stopped meanwhile (`Stopped`), the command is
    sent the same signal (a sumo-rail command stops as on Ctrl-C, keeping what it can) and waited for, killed after
    STOP_WAIT_S, so that it is never left running (holding its output) after the grid is gone."""
    process = subprocess.Popen(argv, stdout=stdout)
    try:
        return process.wait()
    except Stopped as stopped:
        if process.poll() is None:
            process.send_signal(stopped.number)
        try:
            process.wait(timeout=STOP_WAIT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        raise


@dataclass(frozen=True)
class Step:
    """One command of the grid, with its axes' placeholders filled in (`reads` are filled when it runs)."""

    out: Path
    command: tuple[str, ...]
    name: str = ""
    """Where the spec defines it, with its axes' values: "SPEC step 2 (seed=0)"."""
    resume: bool = False
    stdout: Path | None = None
    copy: Path | None = None
    reads: dict[str, Path] = field(default_factory=dict)
    always: bool = False
    """Run every time (a table made from the outputs before it)."""

    def state(self) -> str:
        """"finished", "interrupted" (a resumable run folder with something in it) or "new"."""
        if self.always:
            return "new"
        if self.resume:
            return "interrupted" if self.out.is_dir() and any(self.out.iterdir()) else "new"
        return "finished" if self.out.exists() else "new"

    def argv(self, dry_run: bool = False) -> list[str]:
        """The process to run (with --resume for an interrupted run folder)."""
        values = {name: f"<last line of {path}>" if dry_run else last_line(path) for name, path in self.reads.items()}
        head, *rest = (fill(part, values, "read") for part in self.command)
        return [*RUNNERS.get(head, [head]), *rest, *(["--resume"] if self.state() == "interrupted" else [])]

    def run(self) -> int:
        """Run the step; its output appears only when it succeeds (stdout and copies are written aside, renamed)."""
        self.out.parent.mkdir(parents=True, exist_ok=True)
        if self.copy is not None:
            shutil.copyfile(self.copy, aside(self.out))
            os.replace(aside(self.out), self.out)
            return 0
        if self.stdout is None:
            return run_command(self.argv())
        with aside(self.stdout).open("w") as printed:
            code = run_command(self.argv(), printed)
        if code == 0:
            os.replace(aside(self.stdout), self.stdout)
        return code


def aside(path: Path) -> Path:
    """Where `path` is written before it is renamed into place."""
    return path.with_name(path.name + ".partial")


def last_line(path: Path) -> str:
    """The last non-empty line of a file an earlier step wrote."""
    try:
        return path.read_text().strip().splitlines()[-1].strip()
    except (OSError, IndexError):
        raise click.ClickException(f"{path} holds no value: the step that writes it has not run") from None


def fill(template: str, values: dict[str, Any], where: str) -> str:
    """`template` with each {name} replaced; an unknown name is a one-sentence error naming `where`."""
    def value(match: re.Match) -> str:
        if match.group(1) not in values:
            raise click.UsageError(f"{where}: {{{match.group(1)}}} is neither an axis of the spec nor root or out")
        found = values[match.group(1)]
        if not isinstance(found, dict):
            return str(found)
        key = match.group(2) or "name"
        if key not in found or isinstance(found[key], list):
            raise click.UsageError(f"{where}: {match.group(0)} is not a single value of that axis's tables")
        return str(found[key])
    return PLACEHOLDER.sub(value, template)


def command_parts(part: Any, values: dict[str, Any], axes: dict[str, list], where: str) -> list[str]:
    """One element of a command as the arguments it stands for."""
    if isinstance(part, dict):
        axis = part.get("each")
        if axis not in axes:
            raise click.UsageError(f"{where}: each = {axis!r} is not an axis of the spec")
        return [argument for item in axes[axis] for inner in part.get("args", [])
                for argument in command_parts(inner, values | {axis: item}, axes, where)]
    whole = PLACEHOLDER.fullmatch(part)
    table = values.get(whole.group(1)) if whole and whole.group(2) else None
    if isinstance(table, dict) and isinstance(table.get(whole.group(2)), list):
        return [fill(str(argument), values, where) for argument in table[whole.group(2)]]
    return [fill(part, values | {name: f"{{{name}}}" for name in values.get("_reads", ())}, where)]


def named_axes(templates: list[Any]) -> set[str]:
    """The placeholders used in a step's templates, outside `each` tables (which range over their axis)."""
    names = set()
    for template in templates:
        if isinstance(template, dict):
            names |= named_axes(template.get("args", [])) - {template.get("each")}
        else:
            names |= {match.group(1) for match in PLACEHOLDER.finditer(str(template))}
    return names


def expand(spec: dict, spec_path: Path, axes_override: dict[str, list[str]], root: str = "") -> list[Step]:
    """Every step of `spec` for every combination of the axes its templates name, in the spec's order."""
    axes = {name: [value for value in found if not (isinstance(value, dict) and value.get("default") is False)
                   or name in axes_override] for name, found in spec.get("axes", {}).items()}
    unknown = sorted(set(axes_override) - set(axes))
    if unknown:
        raise click.UsageError(f"--axis {unknown[0]}: {spec_path} has no such axis (axes: {', '.join(axes)})")
    for name, wanted in axes_override.items():  # table values are chosen by name, plain values replaced
        tables = {str(value["name"]): value for value in spec["axes"][name] if isinstance(value, dict)}
        if tables and set(wanted) - set(tables):
            raise click.UsageError(f"--axis {name}: {sorted(set(wanted) - set(tables))[0]} is not one of "
                                   f"{', '.join(tables)}")
        axes[name] = [tables[value] for value in wanted] if tables else wanted
    root = str(root or spec.get("root", "results/" + spec_path.stem))
    steps = []
    for number, step in enumerate(spec.get("step", []), start=1):
        where = f"{spec_path} step {number}"
        if "out" not in step or not (step.get("command") or step.get("copy")):
            raise click.UsageError(f"{where} needs an out and a command (or a copy)")
        if not isinstance(step.get("command", []), list):
            raise click.UsageError(f"{where}: command must be a list of words, e.g. [\"sumo-rail\", \"train\", "
                                   f"\"--seed\", \"{{seed}}\"], got {step['command']!r}")
        reads = step.get("read", {})
        templates = [step["out"], step.get("stdout", ""), step.get("copy", ""), *reads.values(),
                     *step.get("command", [])]
        names = sorted(named_axes(templates) & set(axes))
        for combination in itertools.product(*(axes[name] for name in names)):
            constants = {name: found[0] for name, found in axes.items() if len(found) == 1}  # used anywhere
            values: dict[str, Any] = {"root": root, **constants, **dict(zip(names, combination, strict=True))}
            values["out"] = fill(step["out"], values, where)
            command = [argument for part in step.get("command", [])
                       for argument in command_parts(part, values | {"_reads": reads}, axes, where)]
            optional = {key: Path(fill(step[key], values, where)) for key in ("stdout", "copy") if key in step}
            chosen = [f"{axis}={value['name'] if isinstance(value, dict) else value}"
                      for axis, value in zip(names, combination, strict=True)]
            label = where + (f" ({', '.join(chosen)})" if chosen else "")
            steps.append(Step(Path(values["out"]), tuple(command), label, bool(step.get("resume", False)), **optional,
                              reads={name: Path(fill(path, values, where)) for name, path in reads.items()},
                              always=bool(step.get("always", False))))
    check_outs_differ(steps)
    return steps


def check_outs_differ(steps: list[Step]) -> None:
    """A one-sentence error naming two steps that write one output: the second would never run (its output is
    there) while the grid reported it done."""
    writers: dict[Path, Step] = {}
    for step in steps:
        first = writers.setdefault(step.out.resolve(), step)
        if first is not step:
            raise click.UsageError(f"{first.name} and {step.name} both write {step.out}: give each step its own out "
                                   f"(naming every axis its command names)")


def read_spec(path: Path) -> dict:
    """The spec's TOML, or a one-sentence error."""
    try:
        return tomllib.loads(path.read_text())
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise click.UsageError(f"cannot read the spec {path}: {error}") from None


def parse_axes(pairs: tuple[str, ...]) -> dict[str, list[str]]:
    """`--axis name=v1,v2` options as {name: [v1, v2]}."""
    found = {}
    for pair in pairs:
        name, equals, values = pair.partition("=")
        if not equals or not values:
            raise click.BadParameter(f"{pair!r} is not name=value[,value...]", param_hint="--axis")
        found[name] = values.split(",")
    return found


@click.command(help=__doc__.split("\n\n")[0])
@click.argument("spec_path", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--dry-run", is_flag=True, help="List each step with its state and command; run nothing.")
@click.option("--root", default="", help="Write under this folder instead of the spec's root.")
@click.option("--only", "only", default="", help="Run only the steps whose output path contains this text.")
@click.option("--axis", "axes", multiple=True, help="Give an axis these values, e.g. --axis seed=3,4 or --axis "
                                                     "demos=FILE (a table-valued axis: these of its names).")
def main(spec_path: Path, dry_run: bool, root: str, only: str, axes: tuple[str, ...]) -> None:
    steps = [step for step in expand(read_spec(spec_path), spec_path, parse_axes(axes), root)
             if only in str(step.out)]
    with stopped_by_signals():
        try:
            run_steps(steps, dry_run)
        except Stopped as stopped:  # between two steps: none was running
            raise click.ClickException(f"interrupted by {stopped}; run the same command again to go on") from None
    click.echo(f"{len(steps)} steps done", err=True)


def run_steps(steps: list[Step], dry_run: bool) -> None:
    """Run (or with `dry_run` list) each step not finished, in order; a failed or stopped step is one sentence."""
    for number, step in enumerate(steps, start=1):
        state = step.state()
        click.echo(f"[{number}/{len(steps)}] {state}: {step.out}", err=True)
        if dry_run:
            shown = f"copy {step.copy}" if step.copy else shlex.join(step.argv(dry_run=True))
            click.echo("    " + shown + (f" > {step.stdout}" if step.stdout else ""), err=True)
            continue
        if state == "finished":
            continue
        try:
            code = step.run()
        except Stopped as stopped:
            raise click.ClickException(f"interrupted by {stopped} at {step.out}, whose command was stopped; run the "
                                       f"same command again to go on") from None
        except OSError as error:  # a program that is not there, a copy of a file that is not there
            raise click.ClickException(f"step {step.out} cannot run: {error.filename}: {error.strerror}") from None
        if code != 0:
            raise click.ClickException(f"step {step.out} failed (exit {code}); fix it and run the grid again: "
                                       f"finished steps are skipped")


if __name__ == "__main__":
    main()
