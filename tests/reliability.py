"""Shared by the reliability tests: a small real workspace of the files sumo-rail reads back, the damages any file
can suffer, and the checks on what a command did with them."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner, Result
from sumo_rail_cli.main import cli
from test_cli import SMALL


def train_args(iterations: int = 1) -> tuple[str, ...]:
    """How the workspace's run was made (with --iterations 1)."""
    return ("train", *SMALL, "--demos", "demos.parquet", "--set", "network.shape=mlp", "--set", "network.hidden=4",
            "--set", "rail.directions=2",
            "--set", "rail.top=1", "--iterations", str(iterations), "--set", "bc.epochs=1", "--eval-every", "0",
            "--workers", "1")


TRAIN_ARGS = train_args()


def make_workspace(folder: Path) -> None:
    """Writes into `folder` demos.parquet (2 episodes), run/ (one RAIL iteration) and metrics.parquet (1 episode)."""
    previous = Path.cwd()
    os.chdir(folder)
    try:
        for args in (("record-expert", *SMALL, "--episodes", "2", "--out", "demos.parquet"),
                     (*TRAIN_ARGS, "--out", "run"),
                     ("evaluate", *SMALL, "--policy", "keep", "--episodes", "1", "--out", "metrics.parquet")):
            result = CliRunner().invoke(cli, list(args))
            assert result.exit_code == 0, result.output
    finally:
        os.chdir(previous)


# Damages: what a disk, a crash or a person can do to any file. Each takes the file's path and changes it in place.

def missing(path: Path) -> None:
    path.unlink()


def empty(path: Path) -> None:
    path.write_bytes(b"")


def truncated(path: Path) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def garbage(path: Path) -> None:
    path.write_bytes(np.random.default_rng(0).bytes(path.stat().st_size))


def scrambled_middle(path: Path) -> None:
    """64 bytes in the middle overwritten: a bad sector; the file keeps its size, head and tail."""
    data = bytearray(path.read_bytes())
    middle = len(data) // 2
    data[middle:middle + 64] = np.random.default_rng(1).bytes(64)
    path.write_bytes(bytes(data))


GENERIC = {"missing": missing, "empty": empty, "truncated": truncated, "garbage": garbage}


def assert_refuses_missing_and_garbage(read: Callable[[Path], Any], error: type[Exception], folder: Path, suffix: str,
                                       content: bytes, unreadable: str) -> None:
    """`read` refuses a missing file ("does not exist") and one of garbage `content` (`unreadable`) with `error`."""
    with pytest.raises(error, match="does not exist"):
        read(folder / f"missing{suffix}")
    garbage = folder / f"garbage{suffix}"
    garbage.write_bytes(content)
    with pytest.raises(error, match=unreadable):
        read(garbage)


def fingerprint(folder: Path) -> dict[str, str]:
    """Every file and folder under `folder` with its content's hash."""
    return {str(path.relative_to(folder)): hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else "dir"
            for path in sorted(folder.rglob("*"))}


def assert_one_sentence(result: Result, name: str) -> str:
    """The command failed with one click error line naming `name`, no traceback; returns the message."""
    assert isinstance(result.exception, SystemExit), f"unhandled {result.exception!r}\n{result.output}"
    assert result.exit_code in (1, 2), result.output
    assert "Traceback" not in result.output
    lines = result.stderr.rstrip().splitlines()
    errors = [line for line in lines if line.startswith("Error: ")]
    assert len(errors) == 1 and lines[-1] == errors[0], result.stderr  # one line, the last
    message = errors[0].removeprefix("Error: ")
    assert name in message, message
    assert " ()" not in message and len(message.replace(name, "").split()) >= 3, message  # says what is wrong
    return message



def stopped_after(target: str, number: int, args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    """Run `sumo-rail ARGS` in its own process (in `cwd`), which sends itself signal `number` as soon as `target`
    ("module:attribute", the attribute perhaps dotted: a class's method) returns, as a Ctrl-C or SIGTERM arriving at
    that moment of the command would; its exit code and output."""
    module, attribute = target.split(":")
    owner, _, name = attribute.rpartition(".")
    script = (f"import functools, importlib, os\nfrom sumo_rail_cli.main import cli\n"
              f"owner = importlib.import_module({module!r})\n"
              f"for part in {owner!r}.split('.') if {owner!r} else []:\n    owner = getattr(owner, part)\n"
              f"original = getattr(owner, {name!r})\n\n"
              f"@functools.wraps(original)\ndef stopping(*args, **kwargs):\n"
              f"    result = original(*args, **kwargs)\n    os.kill(os.getpid(), {int(number)})\n    return result\n\n"
              f"setattr(owner, {name!r}, stopping)\ncli({args!r}, prog_name='sumo-rail')\n")
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600, cwd=cwd)
