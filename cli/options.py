"""Options shared by the commands: configuration (defaults, TOML, `--set`), episodes, seeds, workers, outputs."""

from __future__ import annotations

import contextlib
import tomllib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import click
from tqdm import tqdm

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


def episode_options(default_seed: int, default_episodes: int) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """--episodes, --seed and --workers."""
    def decorate(command: Callable[..., Any]) -> Callable[..., Any]:
        command = click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True,
                               help="Worker processes, each running one SUMO; results do not depend on it.")(command)
        command = click.option("--seed", type=click.IntRange(min=0), default=default_seed, show_default=True,
                               help="Base seed; episode k gets its own seed derived from it.")(command)
        return click.option("--episodes", type=click.IntRange(min=1), default=default_episodes, show_default=True,
                            help="Number of episodes.")(command)
    return decorate


def output_options(required: bool) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """--out FILE (Parquet) and --overwrite."""
    def decorate(command: Callable[..., Any]) -> Callable[..., Any]:
        command = click.option("--overwrite", is_flag=True, help="Replace --out if it exists.")(command)
        return click.option("--out", type=click.Path(path_type=Path), required=required,
                            help="Parquet file to write (atomically: nothing is left behind on failure).")(command)
    return decorate


def resolve_config(config_path: Path | None, overrides: tuple[str, ...]) -> Config:
    """Defaults, then the TOML file, then each --set; a bad value is a usage error (exit 2)."""
    try:
        config = Config.from_toml(config_path) if config_path else Config()
        return config.with_overrides(_parse_overrides(overrides)) if overrides else config
    except ConfigError as error:
        raise click.UsageError(str(error)) from error


def check_output(out: Path | None, overwrite: bool) -> None:
    """Refuse an unusable --out before any work starts (usage error, exit 2)."""
    from sumo_rail.datasets import DatasetError, check_output_path

    if out is None:
        return
    try:
        check_output_path(out, overwrite)
    except DatasetError as error:
        raise click.BadParameter(str(error), param_hint="'--out'") from error


@contextlib.contextmanager
def library_errors() -> Iterator[None]:
    """Errors a user can cause in the library become one-sentence click errors (exit 1), never tracebacks."""
    from sumo_rail.backends import BackendError
    from sumo_rail.datasets import DatasetError
    from sumo_rail.policies import PolicyFileError
    from sumo_rail.sim import SimulationError

    try:
        yield
    except (BackendError, DatasetError, PolicyFileError, SimulationError) as error:
        raise click.ClickException(str(error)) from error


def episode_progress(total: int, description: str) -> tqdm:
    """A progress bar over episodes, with rate and time left, on stderr."""
    return tqdm(total=total, desc=description, unit="episode", dynamic_ncols=True)


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
