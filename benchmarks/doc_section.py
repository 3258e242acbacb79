"""Replace one marked section of a Markdown file (each benchmark owns its section of docs/benchmarks.md), and the
options the benchmarks share."""

from __future__ import annotations

import argparse
import os
from pathlib import Path


def write_section(path: Path, name: str, section: str) -> None:
    """Print `section`, then put it between `<!-- bench:NAME -->` markers in `path`, replacing what was there;
    atomic."""
    print(section)
    begin, end = f"<!-- bench:{name} -->", f"<!-- /bench:{name} -->"
    block = f"{begin}\n{section.strip()}\n{end}"
    text = path.read_text() if path.exists() else "# Benchmarks\n\nEach section is written by `make bench`.\n"
    if begin in text:
        head, rest = text.split(begin, 1)
        text = head + block + rest.split(end, 1)[1]
    else:
        text = text.rstrip("\n") + "\n\n" + block + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_suffix(".tmp")
    temporary.write_text(text)
    os.replace(temporary, path)


def bench_parser(description: str | None, episodes: int, episodes_help: str, rounds: int,
                 rounds_help: str) -> argparse.ArgumentParser:
    """The options of a benchmark that alternates rounds of episodes: --episodes, --rounds and --out (the Markdown
    file its section goes in); add its own before parsing."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--episodes", type=int, default=episodes, help=episodes_help)
    parser.add_argument("--rounds", type=int, default=rounds, help=rounds_help)
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks.md"))
    return parser
