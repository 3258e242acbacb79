"""Replace one marked section of a Markdown file (each benchmark owns its section of docs/benchmarks.md)."""

from __future__ import annotations

import os
from pathlib import Path


def write_section(path: Path, name: str, section: str) -> None:
    """Put `section` between `<!-- bench:NAME -->` markers in `path`, replacing what was there; atomic."""
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
