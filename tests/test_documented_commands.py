"""The commands the README and docs/ show run as shown: each `sumo-rail COMMAND` of their code blocks (its shell arrays
such as `S=(--set ...)` expanded) names options the command has and sets only the sections it takes."""

from __future__ import annotations

import functools
import itertools
import re
import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner
from sumo_rail_cli.main import cli

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def documented_commands(text: str) -> list[tuple[str, list[str]]]:
    """(command, its words after the command name) of each `sumo-rail COMMAND ...` line of `text`'s code blocks, its
    continuation lines joined and the arrays the document defines before it (`NAME=(words)`) expanded."""
    arrays: dict[str, list[str]] = {}
    found = []
    for block in re.findall(r"```[a-z]*\n(.*?)```", text, flags=re.DOTALL):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split("  #")[0].strip()
            if (array := re.match(r"^([A-Z]+)=\((.*)\)$", line)) is not None:
                arrays[array[1]] = shlex.split(array[2])
            elif line.startswith("sumo-rail "):
                words = shlex.split(re.sub(r'"\$\{([A-Z]+)\[@\]\}"', lambda name: shlex.join(arrays[name[1]]), line))
                found.append((words[1], words[2:]))
    return found


@functools.cache
def sections_taken(command: str) -> frozenset[str]:
    """The settings sections `command` takes (its --help-settings)."""
    result = CliRunner().invoke(cli, [command, "--help-settings"])
    assert result.exit_code == 0, result.output
    return frozenset(re.findall(r"^\[(\w+)\]$", result.output, flags=re.MULTILINE))


def refused(command: str, words: list[str]) -> list[str]:
    """The words of `command`'s documented call that it would refuse: an option it does not have, a section it does not
    take."""
    assert command in cli.commands, command
    options = {option for param in cli.commands[command].params for option in [*param.opts, *param.secondary_opts]}
    wrong = [word for word in words if word.startswith("--") and word.split("=")[0] not in options]
    settings = [value for option, value in itertools.pairwise(words) if option == "--set"]
    sections = sections_taken(command) if settings else frozenset()
    return wrong + [value for value in settings if value.split(".")[0] not in sections]


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda path: path.name)
def test_every_documented_command_takes_the_options_and_settings_it_is_shown_with(document):
    calls = documented_commands(document.read_text())
    assert [(command, refused(command, words)) for command, words in calls if refused(command, words)] == []


def test_the_check_finds_a_setting_of_a_section_the_command_does_not_take():
    text = "```bash\nA=(--set network.shape=mlp)\nsumo-rail recorded-demos SCENE \"${A[@]}\" --frobnicate \\\n" \
           "    --out d.parquet  # a comment\n```\n"
    (command, words), = documented_commands(text)
    assert refused(command, words) == ["--frobnicate", "network.shape=mlp"]
