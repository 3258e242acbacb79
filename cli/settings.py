"""The settings every command takes: --preset, --config and --set, resolved into one `Config` (and the road it names
checked) and, for a learner's command, its `LearnerSettings`, before any work; --help-settings lists them."""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from sumo_rail.config import PRESETS, SECTIONS, Config, ConfigError, read_config_file


def config_options(command: Callable[..., Any] | None = None, *, learners: tuple[str, ...] = ()) -> Any:
    """Add --preset NAME, --config FILE, repeatable --set SECTION.KEY=VALUE and --help-settings to a command, which
    receives the simulation's settings as one `config: Config` argument and, with `learners` (learner sections such
    as ("network", "bc", "rail")), those sections as one `settings: LearnerSettings` argument (`resolve_settings`).
    Use bare (`@config_options`) or with the learners (`@config_options(learners=...)`)."""
    if command is None:
        return functools.partial(config_options, learners=learners)
    sections = [*SECTIONS, *learners]
    options = [
        click.option("--preset", type=click.Choice(list(PRESETS)), default="paper", show_default=True,
                     help=preset_help()),
        click.option("--config", "config_path", type=click.Path(path_type=Path, dir_okay=False),
                     help=f"TOML file whose {', '.join(f'[{name}]' for name in sections)} tables change the preset "
                          f"(a learner's table this command does not take is left for the command that does)."),
        click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE",
                     help="Change one setting, e.g. --set scenario.lanes=4" + (f" --set {learners[-1]}."
                          f"{_example(learners[-1])}" if learners else " --set env.decision_period_s=1.0") +
                          " (repeatable; after --config); --help-settings lists every one with its default, and a "
                          "value outside its range is refused."),
        click.option("--help-settings", is_flag=True, expose_value=False, is_eager=True,
                     callback=functools.partial(_print_settings, learners=learners),
                     help="List every setting --config and --set change, with its default and help, and exit."),
    ]

    @functools.wraps(command)
    def with_config(*args: Any, preset: str, config_path: Path | None, overrides: tuple[str, ...],
                    **kwargs: Any) -> Any:
        config, settings = resolve_settings(preset, config_path, overrides, learners)
        return command(*args, config=config, **({"settings": settings} if learners else {}), **kwargs)

    for option in reversed(options):
        with_config = option(with_config)
    return with_config


def _example(section: str) -> str:
    return {"rail": "directions=16", "discriminator": "hidden=32", "dagger": "beta=0.3", "gail": "n_steps=256",
            "ppo": "ent_coef=0.02", "network": "shape=linear"}.get(section, "epochs=40")


def preset_help() -> str:
    """--preset's help, made from `PRESETS` itself: every preset with each setting it changes."""
    described = [f"{name}: " + (", ".join(f"{section}.{key}={value}" for section, values in changes.items()
                                          for key, value in values.items()) or "the defaults")
                 for name, changes in PRESETS.items()]
    return ("Named setting, which --config and --set change; " + "; ".join(described) + ". The defaults are the "
            "paper's setting (the 24-beam LIDAR is the whole observation); observation.lane_block=1 adds the cars "
            "one lane over, observation.route_block=1 where the lane leads (lanes that end, merges, exits).")


def _print_settings(ctx: click.Context, param: click.Parameter, value: bool, learners: tuple[str, ...]) -> None:
    if not value or ctx.resilient_parsing:
        return
    from sumo_rail.learning.settings import LearnerSettings
    from sumo_rail.setting_tables import settings_listing

    config = Config()
    sections = {name: getattr(config, name) for name in SECTIONS}
    if learners:
        sections.update(LearnerSettings.defaults(learners).sections)
    click.echo(f"Settings of {ctx.command_path}, each with its default (--preset recommended changes "
               f"observation.*), set by --set SECTION.KEY=VALUE or a --config TOML table [SECTION]:\n")
    click.echo(settings_listing(sections))
    ctx.exit()


def resolve_settings(preset: str, config_path: Path | None, overrides: tuple[str, ...],
                     learners: tuple[str, ...] = ()) -> tuple[Config, Any]:
    """The preset, then the TOML file, then each --set (merged before any check, so that settings valid only together
    may come from both), split into the simulation's `Config` and the `learners`' `LearnerSettings` (None without
    learners). A bad value, a section no command takes, a --set of a learner section
    this command does not take, or a road that cannot be built (a missing or broken network, a route not in it) is a
    usage error (exit 2), before any work. A user's network and traffic file are kept as absolute paths, so that the
    outputs name them from any folder."""
    from sumo_rail.learning.settings import SECTIONS as LEARNER_SECTIONS
    from sumo_rail.setting_tables import merged_tables, read_assignments

    try:
        from_file = read_config_file(config_path) if config_path else {}
        from_words = read_assignments(overrides)
        unknown = sorted((set(from_file) | set(from_words)) - set(SECTIONS) - set(LEARNER_SECTIONS))
        if unknown:
            raise ConfigError(f"unknown config section(s) {unknown}; known: {', '.join([*SECTIONS, *learners])}")
        tables = merged_tables(from_file, from_words)
        config = Config.preset(preset).with_overrides({name: tables[name] for name in SECTIONS if name in tables})
        settings = _learner_settings(learners, tables, from_words)
        if config.scenario.kind != "straight":
            from sumo_rail.sim import network, user_network

            user_network.check_start_window(config.env, network.build(config.scenario))
            config = config.with_overrides({"scenario": user_network.absolute_paths(config.scenario)})
        return config, settings
    except ConfigError as error:
        raise click.UsageError(str(error)) from error


def _learner_settings(learners: tuple[str, ...], tables: dict[str, Any], from_words: dict[str, Any]) -> Any:
    """The learner sections `learners` of `tables` (the file's and the --set words' together); a file's table of
    another learner is left for the command that takes it, a --set word of one is refused."""
    from sumo_rail.learning.settings import LearnerSettings

    foreign = [name for name in from_words if name not in SECTIONS and name not in learners]
    if foreign:
        raise ConfigError(f"--set {foreign[0]}.*: this command takes no [{foreign[0]}] settings"
                          + (f"; its learner settings are {', '.join(f'[{name}]' for name in learners)}"
                             if learners else ""))
    if not learners:
        return None
    return LearnerSettings.defaults(learners).with_tables({name: tables[name] for name in learners if name in tables})
