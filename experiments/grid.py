"""Run an experiment as a grid of sumo-rail commands described by a small TOML spec (experiments/specs/*.toml).

A spec names its axes (methods, seeds, roads, settings: any name with a list of values) and its steps in order:

    root = "results/human_likeness"            # {root} in templates; relative to the current folder
    [axes]
    seed = [0, 1, 2]
    [[step]]
    out = "{root}/bc_s{seed}"                  # the step's output: a file or a run folder
    command = ["sumo-rail", "train", "--seed", "{seed}", "--out", "{out}"]
    resume = true                              # a run folder the command continues with --resume

Each step runs once for every combination of the axes its templates name. Run state is the outputs themselves,
as the commands write them: a step whose output exists is finished (every command writes its files atomically),
except a `resume` step, whose existing, non-empty run folder is handed back to the command with `--resume` (the
command continues an interrupted run and returns at once from a finished one). So the grid can be stopped (Ctrl-C)
and started again at any point, with no marker files and no environment variables. "sumo-rail" and "python" at the
head of a command run in this interpreter's environment.

    python experiments/grid.py experiments/specs/SPEC.toml [--dry-run] [--only TEXT] [--axis seed=0,1]
"""

from __future__ import annotations

import itertools
import re
import shlex
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

import click

PLACEHOLDER = re.compile(r"\{(\w+)\}")


@dataclass(frozen=True)
class Step:
    """One command of the grid, with its placeholders filled in."""

    out: Path
    command: tuple[str, ...]
    resume: bool

    def state(self) -> str:
        """"finished", "interrupted" (a resumable run folder with something in it) or "new"."""
        if self.resume:
            return "interrupted" if self.out.is_dir() and any(self.out.iterdir()) else "new"
        return "finished" if self.out.exists() else "new"

    def argv(self) -> list[str]:
        """The process to run (with --resume for an interrupted run folder)."""
        head, *rest = self.command
        runner = {"sumo-rail": [sys.executable, "-m", "sumo_rail_cli"], "python": [sys.executable]}.get(head, [head])
        return [*runner, *rest, *(["--resume"] if self.state() == "interrupted" else [])]


def fill(template: str, values: dict[str, str], where: str) -> str:
    """`template` with each {name} replaced; an unknown name is a one-sentence error naming `where`."""
    missing = sorted(set(PLACEHOLDER.findall(template)) - set(values))
    if missing:
        raise click.UsageError(f"{where}: {{{missing[0]}}} is neither an axis of the spec nor root or out")
    return PLACEHOLDER.sub(lambda match: values[match.group(1)], template)


def expand(spec: dict, spec_path: Path, axes_override: dict[str, list[str]]) -> list[Step]:
    """Every step of `spec` for every combination of the axes its templates name, in the spec's order."""
    axes = {name: [str(value) for value in values] for name, values in spec.get("axes", {}).items()}
    unknown = sorted(set(axes_override) - set(axes))
    if unknown:
        raise click.UsageError(f"--axis {unknown[0]}: {spec_path} has no such axis (axes: {', '.join(axes)})")
    axes |= axes_override
    root = str(spec.get("root", "results/" + spec_path.stem))
    steps = []
    for number, step in enumerate(spec.get("step", []), start=1):
        where = f"{spec_path} step {number}"
        if "out" not in step or not step.get("command"):
            raise click.UsageError(f"{where} needs an out and a command")
        templates = [step["out"], *step["command"]]
        names = sorted({name for text in templates for name in PLACEHOLDER.findall(text)} & set(axes))
        for combination in itertools.product(*(axes[name] for name in names)):
            values = {"root": root, **dict(zip(names, combination, strict=True))}
            out = fill(step["out"], values, where)
            values["out"] = out
            command = tuple(fill(part, values, where) for part in step["command"])
            steps.append(Step(Path(out), command, bool(step.get("resume", False))))
    return steps


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
@click.option("--only", "only", default="", help="Run only the steps whose output path contains this text.")
@click.option("--axis", "axes", multiple=True, help="Replace an axis's values, e.g. --axis seed=0 (repeatable).")
def main(spec_path: Path, dry_run: bool, only: str, axes: tuple[str, ...]) -> None:
    steps = [step for step in expand(read_spec(spec_path), spec_path, parse_axes(axes)) if only in str(step.out)]
    for number, step in enumerate(steps, start=1):
        state = step.state()
        click.echo(f"[{number}/{len(steps)}] {state}: {step.out}", err=True)
        if dry_run:
            click.echo("    " + shlex.join(step.argv()), err=True)
            continue
        if state == "finished":
            continue
        step.out.parent.mkdir(parents=True, exist_ok=True)
        try:
            code = subprocess.run(step.argv(), check=False).returncode
        except KeyboardInterrupt:
            raise click.ClickException(f"interrupted at {step.out}; run the same command again to go on") from None
        if code != 0:
            raise click.ClickException(f"step {step.out} failed (exit {code}); fix it and run the grid again: "
                                       f"finished steps are skipped")
    click.echo(f"{len(steps)} steps done", err=True)


if __name__ == "__main__":
    main()
