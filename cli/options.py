"""Options shared by the commands, and how each becomes what the library takes: episodes, seeds, workers and
backends, outputs, the expert, the demonstrations, PPO's length and the run folder, and defaults read from the
settings dataclasses (`SettingOption`). The settings (preset, TOML, `--set`, the learners' sections) are `settings`;
how the long commands run (Ctrl-C, errors, progress) is `running`."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from sumo_rail.config import Config

from .demos_options import demos_selection_options
from .output_lock import lock_output
from .param_types import RoadList
from .running import library_errors

if TYPE_CHECKING:
    from sumo_rail.runners.backends import RolloutBackend


class SettingOption(click.Option):
    """An option whose default is a settings dataclass's (`setting_default`): read when --help or the parsing needs
    it, so the value is written once, in the dataclass, whose module stays unimported until then; --help shows it."""

    def get_default(self, ctx: click.Context, call: bool = True) -> Any:
        return super().get_default(ctx, call=True)


def setting_default(module: str, path: str) -> Callable[[], Any]:
    """A function giving the default of the settings dataclass field `path` ("Validation.episodes": a dataclass of
    `module` and its field), for a `SettingOption`."""
    def read() -> Any:
        import importlib

        owner, name = path.split(".")
        field = next(field for field in dataclasses.fields(getattr(importlib.import_module(module), owner))
                     if field.name == name)
        return field.default
    return read


def imitation_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """--demos and which of their episodes count (`demos_selection_options`): what train, dagger and gail share."""
    return click.option("--demos", type=click.Path(path_type=Path, dir_okay=False), required=True,
                        help="Expert demonstrations written by record-expert (or recorded-demos).")(
        demos_selection_options(command))


def timesteps_options(settings: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """What gail and ppo share besides their settings sections: --timesteps (its default that of `settings`,
    "module:Class", GailSettings or PpoSettings) and --resume."""
    module, owner = settings.split(":")
    options = [
        click.option("--timesteps", cls=SettingOption, type=click.IntRange(min=1),
                     default=setting_default(module, f"{owner}.timesteps"), show_default=True,
                     help="Environment decisions in total (rounded up to whole updates of n_steps x envs x egos)."),
        click.option("--resume", is_flag=True,
                     help="Continue the run in --out from its last complete update (with the same settings; "
                          "--timesteps may grow); see docs/reliability.md for what it restores exactly."),
    ]

    def decorate(command: Callable[..., Any]) -> Callable[..., Any]:
        for option in reversed(options):
            command = option(command)
        return command
    return decorate


def egos_option(shared: str, note: str = "") -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """--egos K: `shared` (e.g. "Episodes of a round") drive K at a time in one simulation (`check_egos` checks that
    K egos fit on the road)."""
    return click.option("--egos", type=click.IntRange(min=1), default=1, show_default=True,
                        help=f"{shared} that share one simulation, K at a time, each driving its own ego (the others "
                             f"are traffic to it; an ego that finds no room on the road sits its episode out)."
                             f"{' ' + note if note else ''}")


def roads_option(shared: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """--roads KIND[,KIND...]: `shared` (e.g. "a round's episodes") take these roads in turn; the command receives
    them as a tuple of road names (`RoadList`; None without the option) and checks them (`checked_roads`)."""
    return click.option("--roads", type=RoadList(), default=None, metavar="KIND[,KIND...]",
                        help=f"Spread {shared} over these roads (scenario kinds) in turn: learning on a mix of roads, "
                             f"e.g. straight,merge,exit; each is the configured road with only scenario.kind "
                             f"replaced [default: the configured road].")


def checked_roads(config: Config, roads: tuple[str, ...] | None) -> tuple[str, ...]:
    """The road names of --roads (none without it: the configured road); a usage error (exit 2) for an unknown road
    or one whose observation is not the configured road's size."""
    from sumo_rail.config import ConfigError
    from sumo_rail.runners.road_mix import road_configs

    try:
        road_configs(config, roads or ())
    except ConfigError as error:
        raise click.BadParameter(str(error), param_hint="'--roads'") from error
    return roads or ()


def check_egos(config: Config, egos: int, setting: str = "--egos") -> None:
    """A usage error naming `setting` (the option or setting that gave it) when `egos` egos do not fit on the
    configuration's road."""
    from sumo_rail.sim.network import latest_start_m, road_length_m
    from sumo_rail.sim.starts import check_start_slots

    try:
        check_start_slots(config, egos, road_length_m(config), latest_start_m(config))
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint=f"'{setting}'") from error


def episode_options(default_seed: int, default_episodes: int) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """--episodes and --seed."""
    def decorate(command: Callable[..., Any]) -> Callable[..., Any]:
        command = seed_option("Base seed; episode k gets its own seed derived from it.", default_seed)(command)
        return click.option("--episodes", type=click.IntRange(min=1), default=default_episodes, show_default=True,
                            help="Number of episodes.")(command)
    return decorate


def seed_option(help_text: str, default: int = 0) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """--seed."""
    return click.option("--seed", type=click.IntRange(min=0), default=default, show_default=True, help=help_text)


def output_options(required: bool) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """--out FILE (Parquet) and --overwrite."""
    def decorate(command: Callable[..., Any]) -> Callable[..., Any]:
        command = click.option("--overwrite", is_flag=True, help="Replace --out if it exists.")(command)
        return click.option("--out", type=click.Path(path_type=Path), required=required,
                            help="Parquet file to write (atomically: nothing is left behind on failure).")(command)
    return decorate


def run_folder_options(step: str, eval_every: int) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """What train and dagger share: --workers and the backend, --seed, validation every `eval_every` of their
    `step`s (iteration, round), the run folder --out and --resume."""
    def decorate(command: Callable[..., Any]) -> Callable[..., Any]:
        options = [
            backend_options,
            seed_option("Seed of everything the run draws; the same seed and settings give the same policies."),
            click.option("--eval-every", type=click.IntRange(min=0), default=eval_every, show_default=True,
                         help=f"Evaluate the policy on validation episodes every this many {step}s and after the "
                              f"last (0: never)."),
            click.option("--eval-episodes", cls=SettingOption, type=click.IntRange(min=1),
                         default=setting_default("sumo_rail.learning.validation", "Validation.episodes"),
                         show_default=True,
                         help="Validation episodes per evaluation."),
            click.option("--out", type=click.Path(path_type=Path, file_okay=False), required=True,
                         help="Run folder."),
            click.option("--resume", is_flag=True, help=f"Continue the run in --out from its last complete {step}."),
        ]
        for option in reversed(options):
            command = option(command)
        return command
    return decorate


def backend_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """--workers, --backend process|ray and --address (ray only); build the backend with `build_backend`."""
    command = click.option("--address", metavar="auto|HOST:PORT",
                           help="Ray cluster to run on with --backend ray (default: a local Ray with --workers "
                                "CPUs).")(command)
    command = click.option("--backend", "backend_name", type=click.Choice(["process", "ray"]), default="process",
                           show_default=True,
                           help="process: worker processes on this machine; ray: Ray actors, locally or on a cluster "
                                "(needs pip install 'sumo-rail[ray]').")(command)
    return click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True,
                        help="Worker processes, each running one SUMO; results do not depend on it.")(command)


def build_backend(name: str, workers: int, address: str | None) -> RolloutBackend:
    """The backend of --backend/--workers/--address; --address without --backend ray is a usage error (exit 2),
    a missing Ray a one-sentence error (exit 1)."""
    from sumo_rail.runners.factory import make_backend

    if address is not None and name != "ray":
        raise click.UsageError("--address needs --backend ray")
    with library_errors():
        return make_backend(name, workers, address=address)


def check_output(out: Path | None, overwrite: bool) -> None:
    """Refuse an unusable --out before any work starts (usage error, exit 2), and one another command is writing
    (exit 1); hold it until the command ends (`lock_output`)."""
    from sumo_rail.datasets import DatasetError, check_output_path

    if out is None:
        return
    try:
        check_output_path(out, overwrite)
    except DatasetError as error:
        raise click.BadParameter(str(error), param_hint="'--out'") from error
    lock_output(out)


def check_run_folder(out: Path) -> None:
    """Refuse a run folder --out that cannot be made or written before any work starts (usage error, exit 2), and
    one another command is writing (exit 1); hold it until the command ends (`lock_output`)."""
    from sumo_rail.datasets import DatasetError, check_output_folder

    try:
        check_output_folder(out)
    except DatasetError as error:
        raise click.BadParameter(str(error), param_hint="'--out'") from error
    lock_output(out)


def tensorboard_option(command: Callable[..., Any]) -> Callable[..., Any]:
    """--tensorboard DIR: also log every training row to TensorBoard (optional extra)."""
    return click.option("--tensorboard", "tensorboard_dir", type=click.Path(path_type=Path, file_okay=False),
                        default=None, help="Also write TensorBoard logs into this folder (tensorboard --logdir DIR); "
                                           "log.parquet stays the record. Needs pip install "
                                           "'sumo-rail[tensorboard]'.")(command)


def expert_option(help_text: str, default: str | None = "normal") -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """--expert STYLE|POLICY_FILE: who the expert is; `resolve_expert_option` builds it."""
    return click.option("--expert", "expert", default=default, show_default=default is not None,
                        metavar="STYLE|POLICY_FILE", help=help_text + " A rule-based style (calm, normal, sporty) or a "
                        "policy file whose observation layout is this configuration's.")


def resolve_expert_option(expert: str, config: Config, drives: bool = False) -> tuple[str, Any]:
    """How outputs record the expert of --expert (`experts.expert_reference`: a policy file by absolute path and
    content hash) and its driver (with `drives`, one that can drive or label under the configuration's action
    interface, `experts.check_drives`); an unknown name or an expert of the other interface (a policy file's too) is
    a usage error (exit 2), an unusable policy file a one-sentence error (exit 1)."""
    from sumo_rail.drivers.policies import PolicyFileError, PolicyInterfaceError
    from sumo_rail.runners.experts import check_drives, expert_reference, resolve_expert

    try:
        reference = expert_reference(expert)
        driver = resolve_expert(reference, config)
        if drives:
            check_drives(driver, config)
        return reference, driver
    except PolicyInterfaceError as error:
        raise click.BadParameter(str(error), param_hint="'--expert'") from error
    except PolicyFileError as error:
        raise click.ClickException(str(error)) from error
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="'--expert'") from error
