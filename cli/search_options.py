"""RAIL's search options, what train and step-signal share: ARS's and the discriminator's settings, their defaults
read from RailSettings and DiscriminatorSettings, and the research ones that `train --help` leaves to --help-all."""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any

import click
from sumo_rail_cli.options import SettingOption, egos_option, setting_default
from sumo_rail_cli.param_types import FiniteFloat

if TYPE_CHECKING:
    from sumo_rail.learning.rail.discriminator import DiscriminatorSettings
    from sumo_rail.learning.rail.iteration import RailSettings

RAIL = "sumo_rail.learning.rail.iteration"
DISCRIMINATOR = "sumo_rail.learning.rail.discriminator"

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
        click.option("--step-size", cls=SettingOption, type=FiniteFloat(min=0, min_open=True),
                     default=setting_default(RAIL, "RailSettings.step_size"), show_default=True,
                     help="alpha, the ARS step size (the paper's 0.001 changes 0.1% of decisions in 3 iterations; "
                          "see docs/results.md)."),
        click.option("--noise", cls=SettingOption, type=FiniteFloat(min=0, min_open=True),
                     default=setting_default(RAIL, "RailSettings.noise.initial"), show_default=True,
                     help="nu_init, the perturbation scale."),
        click.option("--noise-increment", cls=SettingOption, type=FiniteFloat(min=0),
                     default=setting_default(RAIL, "RailSettings.noise.increment"), show_default=True,
                     help="tau, added to nu at each check without improvement."),
        click.option("--noise-every", cls=SettingOption, type=click.IntRange(min=1),
                     default=setting_default(RAIL, "RailSettings.noise.every"), show_default=True,
                     help="eta, iterations between noise checks."),
        click.option("--flip-rate", type=FiniteFloat(min=0, max=1, min_open=True, max_open=True), default=None,
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
        click.option("--disc-lr", cls=SettingOption, type=FiniteFloat(min=0, min_open=True),
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
        click.option("--disc-balance", cls=SettingOption, type=FiniteFloat(min=0),
                     default=setting_default(DISCRIMINATOR, "DiscriminatorSettings.balance"), show_default=True,
                     help="Discriminator minibatches weigh pairs by (1 / their action's frequency)^p: 0 uniform, 1 "
                          "every action alike."),
        click.option("--disc-penalty", cls=SettingOption, type=FiniteFloat(min=0),
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
