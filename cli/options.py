"""Options shared by the commands, and how each becomes what the library takes: episodes, seeds, workers and
backends, outputs, the expert, the imitation and run-folder options, and RAIL's search. The configuration (preset,
TOML, `--set`) is `settings`; how the long commands run (Ctrl-C, errors, progress) is `running`."""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
from sumo_rail_cli.running import library_errors

from sumo_rail.config import Config

if TYPE_CHECKING:
    from sumo_rail.learning.rail.discriminator import DiscriminatorSettings
    from sumo_rail.learning.rail.iteration import RailSettings
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


RAIL = "sumo_rail.learning.rail.iteration"
DISCRIMINATOR = "sumo_rail.learning.rail.discriminator"


def imitation_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """--demos, the actor (--policy, --hidden) and its behaviour-cloning initialisation (--bc-epochs,
    --bc-class-balance): what train and gail share."""
    bc_options = [
        click.option("--bc-epochs", type=click.IntRange(min=0), default=20, show_default=True,
                     help="Behaviour-cloning epochs that initialise the policy (0: no BC); few demonstrations need "
                          "more (about 4000 / episodes, e.g. 100 for 40)."),
        click.option("--bc-class-balance", type=click.FloatRange(min=0), default=0.75, show_default=True,
                     help="Exponent p of BC's class weights (1/frequency)^p: 0 plain cross-entropy, 1 all actions "
                          "equal."),
    ]
    for option in reversed(bc_options):
        command = option(command)
    return click.option("--demos", type=click.Path(path_type=Path, dir_okay=False), required=True,
                        help="Expert demonstrations written by record-expert.")(policy_shape_options(command))


def policy_shape_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """The trained policy's layout: --policy (kind) and --hidden."""
    command = click.option("--hidden", type=click.IntRange(min=1), default=10, show_default=True,
                           help="Hidden units of mlp.")(command)
    return click.option("--policy", "kind", type=click.Choice(["linear", "mlp"]), default="mlp", show_default=True,
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
        click.option("--learning-rate", cls=SettingOption, type=click.FloatRange(min=0, min_open=True),
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


def check_egos(config: Config, egos: int) -> None:
    """A usage error when `egos` egos do not fit on the configuration's road."""
    from sumo_rail.sim.starts import start_slots

    try:
        start_slots(config, egos)
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
    """Refuse an unusable --out before any work starts (usage error, exit 2)."""
    from sumo_rail.datasets import DatasetError, check_output_path

    if out is None:
        return
    try:
        check_output_path(out, overwrite)
    except DatasetError as error:
        raise click.BadParameter(str(error), param_hint="'--out'") from error


def check_run_folder(out: Path) -> None:
    """Refuse a run folder --out that cannot be made or written before any work starts (usage error, exit 2)."""
    from sumo_rail.datasets import DatasetError, check_output_folder

    try:
        check_output_folder(out)
    except DatasetError as error:
        raise click.BadParameter(str(error), param_hint="'--out'") from error


def tensorboard_option(command: Callable[..., Any]) -> Callable[..., Any]:
    """--tensorboard DIR: also log every training row to TensorBoard (optional extra)."""
    return click.option("--tensorboard", "tensorboard_dir", type=click.Path(path_type=Path, file_okay=False),
                        default=None, help="Also write TensorBoard logs into this folder (tensorboard --logdir DIR); "
                                           "log.parquet stays the record. Needs pip install "
                                           "'sumo-rail[tensorboard]'.")(command)


RESEARCH_OPTIONS = frozenset({"flip_rate", "fitness", "reward", "traffic", "episodes_per_rollout", "freeze_normalizer",
                              "disc_reward", "disc_balance", "disc_penalty", "disc_replay"})
"""train's options that only research uses (ablations, remedies that did not become defaults; the committed
experiments pass them): `train --help` leaves them out, `train --help-all` lists them."""


class ResearchOptionsCommand(click.Command):
    """A command whose `research` options (parameter names) work as any other but are listed only by --help-all, so
    that --help shows what a user sets."""

    def __init__(self, *args: Any, research: frozenset[str] = frozenset(), **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.research = research
        self.params.append(click.Option(["--help-all"], is_flag=True, expose_value=False, is_eager=True,
                                        callback=self._help_all, help="Show the research options too, and exit."))

    def _help_all(self, ctx: click.Context, param: click.Parameter, value: bool) -> None:
        if value and not ctx.resilient_parsing:
            ctx.meta["help_all"] = True
            click.echo(ctx.get_help(), color=ctx.color)
            ctx.exit()

    def format_options(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        records: dict[bool, list[tuple[str, str]]] = {False: [], True: []}
        for param in self.get_params(ctx):
            record = param.get_help_record(ctx)
            if record is not None:
                records[param.name in self.research].append(record)
        with formatter.section("Options"):
            formatter.write_dl(records[False])
        if ctx.meta.get("help_all"):
            with formatter.section("Research options (ablations and remedies no default uses)"):
                formatter.write_dl(records[True])
        elif records[True]:
            formatter.write_paragraph()
            formatter.write_text(f"{len(records[True])} research options (ablations and remedies no default uses) "
                                 f"are listed by --help-all.")


@dataclass(frozen=True)
class SearchOptions:
    """The ARS and discriminator options of `search_options`, as given."""

    directions: int
    top: int | None
    step_size: float
    noise: float
    noise_increment: float
    noise_every: int
    flip_rate: float | None
    fitness: str
    reward: str
    traffic: str
    episodes_per_rollout: int
    egos: int
    rollout_decisions: int | None
    freeze_normalizer: bool
    disc_hidden: int
    disc_lr: float
    disc_steps: int
    disc_reward: str
    disc_balance: float
    disc_penalty: float
    disc_replay: int

    def settings(self, seed: int) -> tuple[RailSettings, DiscriminatorSettings]:
        """The RAIL and discriminator settings; an inconsistent combination is a usage error (exit 2)."""
        from sumo_rail.learning.rail.ars import NoiseAdaptation
        from sumo_rail.learning.rail.discriminator import DiscriminatorSettings
        from sumo_rail.learning.rail.iteration import RailSettings

        try:
            rail = RailSettings(directions=self.directions, top=self.top, step_size=self.step_size,
                                noise=NoiseAdaptation(self.noise, self.noise_increment, self.noise_every), seed=seed,
                                common_traffic=self.traffic == "common", episodes_per_rollout=self.episodes_per_rollout,
                                egos=self.egos, rollout_decisions=self.rollout_decisions,
                                freeze_normalizer=self.freeze_normalizer, fitness=self.fitness,
                                flip_rate=self.flip_rate, reward=self.reward)
            discriminator = DiscriminatorSettings(hidden=self.disc_hidden, learning_rate=self.disc_lr,
                                                  steps_per_iteration=self.disc_steps, seed=seed,
                                                  reward_form=self.disc_reward, balance=self.disc_balance,
                                                  gradient_penalty=self.disc_penalty, replay=self.disc_replay)
        except ValueError as error:
            raise click.UsageError(str(error)) from error
        return rail, discriminator


def search_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """RAIL's ARS and discriminator options, what train and step-signal share; the command receives them as one
    `search: SearchOptions` argument."""
    options = [
        click.option("--directions", cls=SettingOption, type=click.IntRange(min=1),
                     default=setting_default(RAIL, "RailSettings.directions"), show_default=True,
                     help="N, directions."),
        click.option("--top", type=click.IntRange(min=1), default=None,
                     help="b, best directions kept [default: N / 2]."),
        click.option("--step-size", cls=SettingOption, type=click.FloatRange(min=0, min_open=True),
                     default=setting_default(RAIL, "RailSettings.step_size"), show_default=True,
                     help="alpha, the ARS step size (the paper's 0.001 changes 0.1% of decisions in 3 iterations; "
                          "see docs/results.md)."),
        click.option("--noise", cls=SettingOption, type=click.FloatRange(min=0, min_open=True),
                     default=setting_default(RAIL, "RailSettings.noise.initial"), show_default=True,
                     help="nu_init, the perturbation scale."),
        click.option("--noise-increment", cls=SettingOption, type=click.FloatRange(min=0),
                     default=setting_default(RAIL, "RailSettings.noise.increment"), show_default=True,
                     help="tau, added to nu at each check without improvement."),
        click.option("--noise-every", cls=SettingOption, type=click.IntRange(min=1),
                     default=setting_default(RAIL, "RailSettings.noise.every"), show_default=True,
                     help="eta, iterations between noise checks."),
        click.option("--flip-rate", type=click.FloatRange(min=0, max=1, min_open=True, max_open=True), default=None,
                     help="Set nu at every iteration so that the perturbations change this share of the policy's "
                          "decisions on the expert's states (replaces --noise, --noise-increment, --noise-every)."),
        click.option("--fitness", cls=SettingOption, type=click.Choice(["std", "rank"]),
                     default=setting_default(RAIL, "RailSettings.fitness"), show_default=True,
                     help="std: returns divided by their std (ARS); rank: centred ranks (Salimans et al. 2017)."),
        click.option("--reward", cls=SettingOption, type=click.Choice(["discriminator", "agreement"]),
                     default=setting_default(RAIL, "RailSettings.reward"), show_default=True,
                     help="discriminator: RAIL's. agreement: a control, not imitation: the expert is asked at every "
                          "decision of every rollout and the return is the share of decisions it would have made alike "
                          "(what the search reaches with it bounds what any reward can)."),
        click.option("--traffic", cls=SettingOption, type=click.Choice(["common", "independent"]),
                     default=setting_default(RAIL, "RailSettings.common_traffic",
                                             lambda common: "common" if common else "independent"),
                     show_default=True,
                     help="common: every direction of an iteration drives the same episodes (common random numbers); "
                          "independent: each direction its own."),
        click.option("--episodes-per-rollout", cls=SettingOption, type=click.IntRange(min=1),
                     default=setting_default(RAIL, "RailSettings.episodes_per_rollout"), show_default=True,
                     help="Episodes each perturbed rollout drives (its return is their mean)."),
        egos_option("Rollouts of an iteration", "1: one rollout per simulation, as the paper."),
        click.option("--rollout-decisions", type=click.IntRange(min=1), default=None, metavar="D",
                     help="Make each rollout D decisions of its ego, respawning it whenever an episode ends, so the "
                          "egos of a road never wait for each other (with --egos 8: ~4x the decisions per core); its "
                          "return is the reward per decision [default: one whole episode, the paper's]."),
        click.option("--freeze-normalizer/--merge-normalizer", cls=SettingOption,
                     default=setting_default(RAIL, "RailSettings.freeze_normalizer"), show_default=True,
                     help="Keep BC's observation statistics, or merge every rollout's states into them (the "
                          "paper's)."),
        click.option("--disc-hidden", cls=SettingOption, type=click.IntRange(min=1),
                     default=setting_default(DISCRIMINATOR, "DiscriminatorSettings.hidden"), show_default=True,
                     help="Discriminator units per hidden layer."),
        click.option("--disc-lr", cls=SettingOption, type=click.FloatRange(min=0, min_open=True),
                     default=setting_default(DISCRIMINATOR, "DiscriminatorSettings.learning_rate"), show_default=True,
                     help="Discriminator Adam step size."),
        click.option("--disc-steps", cls=SettingOption, type=click.IntRange(min=1),
                     default=setting_default(DISCRIMINATOR, "DiscriminatorSettings.steps_per_iteration"),
                     show_default=True,
                     help="Discriminator gradient steps per iteration."),
        click.option("--disc-reward", cls=SettingOption, type=click.Choice(["logit", "contrast"]),
                     default=setting_default(DISCRIMINATOR, "DiscriminatorSettings.reward_form"), show_default=True,
                     help="logit: log D - log(1 - D), the paper's; contrast: minus its mean over the actions at the "
                          "same state (rewards the choice of action, not the state)."),
        click.option("--disc-balance", cls=SettingOption, type=click.FloatRange(min=0),
                     default=setting_default(DISCRIMINATOR, "DiscriminatorSettings.balance"), show_default=True,
                     help="Discriminator minibatches weigh pairs by (1 / their action's frequency)^p: 0 uniform, 1 "
                          "every action alike."),
        click.option("--disc-penalty", cls=SettingOption, type=click.FloatRange(min=0),
                     default=setting_default(DISCRIMINATOR, "DiscriminatorSettings.gradient_penalty"),
                     show_default=True,
                     help="Weight of the gradient penalty on expert pairs (R1)."),
        click.option("--disc-replay", cls=SettingOption, type=click.IntRange(min=1),
                     default=setting_default(DISCRIMINATOR, "DiscriminatorSettings.replay"), show_default=True,
                     help="Iterations of policy pairs the discriminator trains on (1: the current one)."),
    ]
    names = [field.name for field in fields(SearchOptions)]

    @functools.wraps(command)
    def with_search(*args: Any, **kwargs: Any) -> Any:
        search = SearchOptions(**{name: kwargs.pop(name) for name in names})
        return command(*args, search=search, **kwargs)

    for option in reversed(options):
        with_search = option(with_search)
    return with_search


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
