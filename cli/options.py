"""Options shared by the commands: the configuration from defaults, a TOML file and `--set` overrides."""

from __future__ import annotations

import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from sumo_rail.config import Config, ConfigError


def config_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """Add --config FILE and repeatable --set SECTION.KEY=VALUE to a command."""
    command = click.option(
        "--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE",
        help="Override one setting, e.g. --set scenario.lanes=4 --set env.decision_period_s=1.0 (repeatable).",
    )(command)
    return click.option(
        "--config", "config_path", type=click.Path(path_type=Path, dir_okay=False),
        help="TOML file with [scenario], [lidar] and [env] tables overriding the defaults.",
    )(command)


def resolve_config(config_path: Path | None, overrides: tuple[str, ...]) -> Config:
    """Defaults, then the TOML file, then each --set; a bad value is a usage error (exit 2)."""
    try:
        config = Config.from_toml(config_path) if config_path else Config()
        return config.with_overrides(_parse_overrides(overrides)) if overrides else config
    except ConfigError as error:
        raise click.UsageError(str(error)) from error


def _parse_overrides(overrides: tuple[str, ...]) -> dict[str, dict[str, Any]]:
    sections: dict[str, dict[str, Any]] = {}
    for item in overrides:
        key, separator, raw = item.partition("=")
        section, dot, name = key.strip().partition(".")
        if not separator or not dot or not section or not name:
            raise ConfigError(f"--set expects SECTION.KEY=VALUE, got {item!r}")
        try:
            value = tomllib.loads(f"value = {raw.strip()}")["value"]
        except tomllib.TOMLDecodeError as error:
            raise ConfigError(f"--set {key.strip()} has an unreadable value {raw.strip()!r}") from error
        sections.setdefault(section, {})[name] = value
    return sections
