"""Every command's --preset help names every preset and each setting it changes, as `PRESETS` defines them."""

from __future__ import annotations

import click
from sumo_rail_cli.main import cli

from sumo_rail.config import PRESETS


def commands_with_a_preset(group: click.Group) -> dict[str, click.Command]:
    """Every command of the group (and of its subgroups) that takes --preset."""
    found = {}
    for name, command in group.commands.items():
        if isinstance(command, click.Group):
            found |= {f"{name} {sub}": found_command for sub, found_command in commands_with_a_preset(command).items()}
        elif any(param.name == "preset" for param in command.params):
            found[name] = command
    return found


def test_every_preset_help_names_every_preset_and_every_setting_it_changes():
    commands = commands_with_a_preset(cli)
    assert {"record-expert", "train", "dagger", "gail", "evaluate"} <= set(commands)
    for name, command in commands.items():
        help_text = " ".join(next(param for param in command.params if param.name == "preset").help.split())
        for preset, changes in PRESETS.items():
            settings = [f"{section}.{key}={value}" for section, values in changes.items()
                        for key, value in values.items()]
            described = f"{preset}: " + (", ".join(settings) or "the defaults")
            assert described in help_text, f"{name}'s --preset help lacks {described!r}: {help_text}"
