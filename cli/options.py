"""Options shared by the commands, and how each becomes what the library takes: episodes, seeds, workers and
backends, outputs, the expert, the imitation, PPO and run-folder options, and defaults read from the settings
dataclasses (`SettingOption`). RAIL's search options are `search_options`; the configuration (preset, TOML, `--set`)
is `settings`; how the long commands run (Ctrl-C, errors, progress) is `running`."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
from sumo_rail_cli.demos_options import demos_selection_options
from sumo_rail_cli.output_lock import lock_output
from sumo_rail_cli.param_types import FiniteFloat
from sumo_rail_cli.running import library_errors

from sumo_rail.config import Config

if TYPE_CHECKING:
    from sumo_rail.runners.backends import RolloutBackend


class SettingOption(click.Option):
    """An option whose default is a settings dataclass's (`setting_default`): read when --help or the parsing needs
    it, so the value is written once, in the dataclass, whose module stays unimported until then; --help shows it."""

    def get_default(self, ctx: click.Context, call: bool = True) -> Any:
        return super().get_default(ctx, call=True)


def setting_default(module: str, path: str, convert: Callable[[Any], Any] = lambda value: value) -> Callable[[], Any]:
    """A function giving the default of the settings field `path` ("RailSettings.noise.initial": a dataclass of
    `module`, then fields) through `convert`, for a `SettingOption`."""
    def read() -> Any:
        import importlib

        owner, *names = path.split(".")
        value: Any = getattr(importlib.import_module(module), owner)
        for name in names:
            value = _field_default(value, name) if dataclasses.is_dataclass(value) and isinstance(value, type) \
                else getattr(value, name)
        return convert(value)
    return read


def _field_default(cls: type, name: str) -> Any:
    field = next(field for field in dataclasses.fields(cls) if field.name == name)
    return field.default_factory() if field.default is dataclasses.MISSING else field.default  # type: ignore[misc]


def imitation_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """--demos (`demos_selection_options`), the actor (--policy, --hidden) and its behaviour-cloning initialisation
    (--bc-epochs, --bc-class-balance): what train, dagger and gail share."""
    bc_options = [
        click.option("--bc-epochs", cls=SettingOption, type=click.IntRange(min=0),
                     default=setting_default("sumo_rail.learning.bc", "IMITATION_BC.epochs"), show_default=True,
                     help="Behaviour-cloning epochs that initialise the policy (0: no BC); few demonstrations need "
                          "more (about 4000 / episodes, e.g. 100 for 40)."),
        click.option("--bc-class-balance", cls=SettingOption, type=FiniteFloat(min=0),
                     default=setting_default("sumo_rail.learning.bc", "IMITATION_BC.class_balance"), show_default=True,
                     help="Exponent p of BC's class weights (1/frequency)^p: 0 plain cross-entropy, 1 all actions "
                          "equal."),
    ]
    for option in reversed(bc_options):
        command = option(command)
    return click.option("--demos", type=click.Path(path_type=Path, dir_okay=False), required=True,
                        help="Expert demonstrations written by record-expert.")(
        demos_selection_options(policy_shape_options(command)))


def policy_shape_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """The trained policy's layout: --policy (kind) and --hidden."""
    command = click.option("--hidden", cls=SettingOption, type=click.IntRange(min=1),
                           default=setting_default("sumo_rail.learning.dagger", "DaggerSettings.hidden"),
                           show_default=True, help="Hidden units of mlp.")(command)
    return click.option("--policy", "kind", cls=SettingOption, type=click.Choice(["linear", "mlp"]),
                        default=setting_default("sumo_rail.learning.dagger", "DaggerSettings.kind"), show_default=True,
                        help="linear: obs -> 5 logits; mlp: obs -> --hidden tanh units -> 5 logits.")(command)


def ppo_options(settings: str, critic_help: str = "") -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """What gail and ppo share: --timesteps, --envs, --egos, --n-steps, --learning-rate, --normalize-reward (their
    defaults those of `settings`, "module:Class", GailSettings or PpoSettings), --critic-warmup and --resume.
    --critic-warmup's default is the settings' unless `critic_help` (which ends its help) says another."""
    module, owner = settings.split(":")

    def default(name: str) -> Callable[[], Any]:
        return setting_default(module, f"{owner}.{name}")

    critic_default: dict[str, Any] = ({"cls": SettingOption, "default": default("critic_warmup"), "show_default": True}
                                      if not critic_help else {"default": None})
    options = [
        click.option("--timesteps", cls=SettingOption, type=click.IntRange(min=1), default=default("timesteps"),
                     show_default=True,
                     help="Environment decisions in total (rounded up to whole updates of --n-steps x --envs x "
                          "--egos)."),
        click.option("--envs", cls=SettingOption, type=click.IntRange(min=1), default=default("envs"),
                     show_default=True, help="Environment processes; unlike train's --workers, the result depends on "
                                             "it."),
        click.option("--egos", cls=SettingOption, type=click.IntRange(min=1), default=default("egos"),
                     show_default=True,
                     help="Egos per environment process, sharing its simulation (PPO's envs are --envs x --egos): an "
                          "ego whose episode ends is replaced at once by a new one in the start window while the "
                          "others drive on. The result depends on it."),
        click.option("--n-steps", cls=SettingOption, type=click.IntRange(min=1), default=default("n_steps"),
                     show_default=True, help="PPO decisions per env (ego) and update."),
        click.option("--learning-rate", cls=SettingOption, type=FiniteFloat(min=0, min_open=True),
                     default=default("learning_rate"), show_default=True, help="PPO's Adam step size."),
        click.option("--normalize-reward/--no-normalize-reward", cls=SettingOption, default=default("normalize_reward"),
                     show_default=True,
                     help="Divide PPO's rewards by the running std of the discounted return and clip them to +-10 "
                          "(Stable-Baselines3's VecNormalize), so that one collision cannot swamp the critic."),
        click.option("--critic-warmup", type=click.IntRange(min=0), metavar="K", **critic_default,
                     help=f"First K updates with the actor frozen, only the critic learning (they count in "
                          f"--timesteps){critic_help}."),
        click.option("--resume", is_flag=True,
                     help="Continue the run in --out from its last complete update (with the same options; "
                          "--timesteps may grow); see docs/reliability.md for what it restores exactly."),
    ]

    def decorate(command: Callable[..., Any]) -> Callable[..., Any]:
        for option in reversed(options):
            command = option(command)
        return command
    return decorate


DEFAULT_BATCH = 64
"""PPO's minibatch size [decisions] when none is given, or an update's decisions if fewer."""


def minibatch_size(requested: int | None, n_steps: int, envs: int, egos: int) -> int:
    """PPO's minibatch size: `requested`, else DEFAULT_BATCH or an update's n_steps x envs x egos decisions if fewer
    (what Stable-Baselines3 does then, one minibatch of the whole update, without its warning)."""
    return requested if requested is not None else min(DEFAULT_BATCH, n_steps * envs * egos)


def egos_option(shared: str, note: str = "") -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """--egos K: `shared` (e.g. "Episodes of a round") drive K at a time in one simulation (`check_egos` checks that
    K egos fit on the road)."""
    return click.option("--egos", type=click.IntRange(min=1), default=1, show_default=True,
                        help=f"{shared} that share one simulation, K at a time, each driving its own ego (the others "
                             f"are traffic to it; an ego that finds no room on the road sits its episode out)."
                             f"{' ' + note if note else ''}")


def roads_option(shared: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """--roads KIND[,KIND...]: `shared` (e.g. "a round's episodes") take these roads in turn; the command receives
    them checked (`checked_roads`) as a tuple of road names."""
    return click.option("--roads", default="", metavar="KIND[,KIND...]",
                        help=f"Spread {shared} over these roads (scenario kinds) in turn: learning on a mix of roads, "
                             f"e.g. straight,merge,exit; each is the configured road with only scenario.kind "
                             f"replaced [default: the configured road].")


def checked_roads(config: Config, roads: str) -> tuple[str, ...]:
    """The road names of --roads; a usage error (exit 2) for an unknown road or one whose observation is not the
    configured road's size."""
    from sumo_rail.config import ConfigError
    from sumo_rail.runners.road_mix import parse_roads, road_configs

    names = parse_roads(roads)
    try:
        road_configs(config, names)
    except ConfigError as error:
        raise click.BadParameter(str(error), param_hint="'--roads'") from error
    return names


def check_egos(config: Config, egos: int) -> None:
    """A usage error when `egos` egos do not fit on the configuration's road."""
    from sumo_rail.sim.network import latest_start_m, road_length_m
    from sumo_rail.sim.starts import check_start_slots

    try:
        check_start_slots(config, egos, road_length_m(config), latest_start_m(config))
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="'--egos'") from error


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


def expert_option(help_text: str, *aliases: str, default: str | None = "normal"
                  ) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """--expert STYLE|POLICY_FILE (aliases --style and `aliases`): who the expert is; `resolve_expert_option` builds
    it."""
    return click.option("--expert", "--style", *aliases, "expert", default=default, show_default=default is not None,
                        metavar="STYLE|POLICY_FILE", help=help_text + " A rule-based style (calm, normal, sporty) or a "
                        "policy file whose observation layout is this configuration's.")


def resolve_expert_option(expert: str, config: Config) -> tuple[str, Any]:
    """How outputs record the expert of --expert (`experts.expert_reference`: a policy file by absolute path and
    content hash) and its driver; an unknown name is a usage error (exit 2), an unusable policy file a one-sentence
    error (exit 1)."""
    from sumo_rail.drivers.policies import PolicyFileError
    from sumo_rail.runners.experts import expert_reference, resolve_expert

    try:
        reference = expert_reference(expert)
        return reference, resolve_expert(reference, config)
    except PolicyFileError as error:
        raise click.ClickException(str(error)) from error
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="'--expert'") from error
