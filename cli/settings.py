"""The settings every command takes: --preset, --config and --set, resolved into one `Config` (and the road it names
checked) before any work."""

from __future__ import annotations

import functools
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from sumo_rail.config import PRESETS, Config, ConfigError


def config_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """Add --preset NAME, --config FILE and repeatable --set SECTION.KEY=VALUE to a command, which receives the
    settings they make as one `config: Config` argument (`resolve_config`)."""
    options = [
        click.option("--preset", type=click.Choice(list(PRESETS)), default="paper", show_default=True,
                     help=preset_help()),
        click.option("--config", "config_path", type=click.Path(path_type=Path, dir_okay=False),
                     help="TOML file whose [scenario], [lidar], [env], [observation] and [expert] tables change the "
                          "preset."),
        click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE",
                     help="Change one setting, e.g. --set scenario.lanes=4 --set env.decision_period_s=1.0 "
                          "(repeatable; after --config); every number has a range, stated with its default in "
                          "sumo_rail/config.py, and a value outside it is refused."),
    ]

    @functools.wraps(command)
    def with_config(*args: Any, preset: str, config_path: Path | None, overrides: tuple[str, ...],
                    **kwargs: Any) -> Any:
        return command(*args, config=resolve_config(preset, config_path, overrides), **kwargs)

    for option in reversed(options):
        with_config = option(with_config)
    return with_config


def preset_help() -> str:
    """--preset's help, made from `PRESETS` itself: every preset with each setting it changes."""
    described = [f"{name}: " + (", ".join(f"{section}.{key}={value}" for section, values in changes.items()
                                          for key, value in values.items()) or "the defaults")
                 for name, changes in PRESETS.items()]
    return ("Named setting, which --config and --set change; " + "; ".join(described) + ". The defaults are the "
            "paper's setting (the 24-beam LIDAR is the whole observation); observation.lane_block=1 adds the cars "
            "one lane over, observation.route_block=1 where the lane leads (lanes that end, merges, exits).")


def resolve_config(preset: str, config_path: Path | None, overrides: tuple[str, ...]) -> Config:
    """The preset, then the TOML file, then each --set; a bad value, or a road that cannot be built (a missing or
    broken network, a route not in it), is a usage error (exit 2), before any work. A user's network and traffic
    file are kept as absolute paths, so that the outputs name them from any folder."""
    try:
        config = Config.preset(preset)
        config = config.with_toml(config_path) if config_path else config
        config = config.with_overrides(_parse_overrides(overrides)) if overrides else config
        if config.scenario.kind != "straight":
            from sumo_rail.sim import network, user_network

            user_network.check_start_window(config.env, network.build(config.scenario))
            config = config.with_overrides({"scenario": user_network.absolute_paths(config.scenario)})
        return config
    except ConfigError as error:
        raise click.UsageError(str(error)) from error


def _parse_overrides(overrides: tuple[str, ...]) -> dict[str, dict[str, Any]]:
    sections: dict[str, dict[str, Any]] = {}
    for item in overrides:
        key, separator, raw = item.partition("=")
        section, dot, name = key.strip().partition(".")
        if not separator or not dot or not section or not name:
            raise ConfigError(f"--set expects SECTION.KEY=VALUE, got {item!r}")
        raw = raw.strip()
        try:
            value = tomllib.loads(f"value = {raw}")["value"]
        except tomllib.TOMLDecodeError as error:
            if not raw or raw[0] in "\"'[{":
                raise ConfigError(f"--set {key.strip()} has an unreadable value {raw!r}") from error
            value = raw  # bare words (scenario.kind=merge, a file's path, a route's edges) are a string
        sections.setdefault(section, {})[name] = value
    return sections
