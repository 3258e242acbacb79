"""The command `step-signal`: the meter of one ARS step (its signal and where it points), without training."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from sumo_rail.learning.rail.step_signal import REWARD_VARIANTS

from .demos_options import check_demos
from .options import (
    backend_options,
    build_backend,
    check_egos,
    check_output,
    expert_option,
    resolve_expert_option,
    seed_option,
)
from .progress import complete, progress
from .running import interruptible_run, library_errors
from .settings import config_options

if TYPE_CHECKING:
    from sumo_rail.config import Config
    from sumo_rail.learning.settings import LearnerSettings


@click.command("step-signal")
@config_options(learners=("rail", "discriminator"))
@click.option("--demos", type=click.Path(path_type=Path, dir_okay=False), required=True,
              help="Expert demonstrations (the discriminator's expert pairs and the flip rate's states).")
@click.option("--policy", "policy_path", type=click.Path(path_type=Path, dir_okay=False), required=True,
              help="Policy file at whose weights the step is measured (e.g. a run's policy_bc.npz).")
@click.option("--zero-weights", is_flag=True,
              help="Measure at all-zero weights of the policy's shape and normaliser (RAIL without BC).")
@expert_option("Who is asked at every decision for agreement [default: the demonstrations' expert].", default=None)
@click.option("--discriminator", "rewards", multiple=True, type=click.Choice(list(REWARD_VARIANTS)),
              default=tuple(REWARD_VARIANTS), show_default=True,
              help="Discriminators whose rewards are measured, as changes to the [discriminator] settings "
                   "(repeatable).")
@click.option("--warmup-rounds", type=click.IntRange(min=0), default=5, show_default=True,
              help="Training calls of each discriminator on the policy's perturbed rollouts before the measured step.")
@backend_options
@seed_option("Seed of the directions, the traffic draws and the discriminators.")
@click.option("--out", type=click.Path(path_type=Path, dir_okay=False), default=None,
              help="JSON file for the report (with its settings and provenance), written atomically.")
def step_signal_command(config: Config, settings: LearnerSettings, demos: Path, policy_path: Path,
                        zero_weights: bool, expert: str | None, rewards: tuple[str, ...], warmup_rounds: int,
                        workers: int, backend_name: str, address: str | None, seed: int,
                        out: Path | None) -> None:
    """Measure one ARS step of RAIL without training: how much of it two independent draws of traffic agree on
    (signal) and whether the directions the discriminator's reward prefers raise agreement with the expert
    (alignment), with 95% intervals over the directions. Its settings are the [rail] and [discriminator] sections of
    --config and --set, as train's (--help-settings lists them)."""
    check_output(out, overwrite=True)  # the report replaces an earlier one
    rail = dataclasses.replace(settings.rail, seed=seed)
    discriminator_settings = dataclasses.replace(settings.discriminator, seed=seed)
    check_egos(config, rail.egos, "rail.egos")
    if rail.directions < 3:
        raise click.UsageError("rail.directions must be at least 3: the meter correlates the draws across directions")
    import numpy as np

    from sumo_rail.datasets import write_bytes_atomically
    from sumo_rail.drivers.policies import Policy, load_policy
    from sumo_rail.learning.rail.iteration import calibration_states
    from sumo_rail.learning.rail.noise import directions, noise_for_flip_rate
    from sumo_rail.learning.rail.step_signal import Meter, measure, variants
    from sumo_rail.runners.experts import demonstrations_expert, resolve_expert
    from sumo_rail.runners.tables import provenance, read_demonstrations
    from sumo_rail.sim.actions import action_count
    from sumo_rail.sim.observation import observation_space

    check_demos(demos, config, include_failed=True, other_road=True)  # another interface: exit 2, as train's
    with library_errors():
        demonstrations = read_demonstrations(demos, observation_space(config).shape[0], interface=config.actions)
        policy, _ = load_policy(policy_path)
    if expert is not None:
        expert, asked = resolve_expert_option(expert, config)
    else:
        with library_errors():  # demonstrations of recorded drivers have no expert to ask: one sentence
            expert = demonstrations_expert(demonstrations.metadata)
            asked = resolve_expert(expert, config, recorded_by=demos)
    if policy.shape.observation_size != demonstrations.observations.shape[1]:
        raise click.UsageError(f"policy {policy_path} sees {policy.shape.observation_size} observation values but "
                               f"the configuration gives {demonstrations.observations.shape[1]}")
    if policy.shape.actions != (count := action_count(config.actions)):
        raise click.UsageError(f"policy {policy_path} chooses among {policy.shape.actions} actions but the "
                               f"configuration's action interface has {count} "
                               f"(actions.interface={config.actions.interface})")
    policy = policy.decoded_by(config.actions.decoding)  # as every command reads a policy file: the run's decoding
    if zero_weights:
        policy = Policy(policy.shape, np.zeros_like(policy.parameters), policy.observation_mean,
                        policy.observation_std)
    calibration = calibration_states(demonstrations.observations)
    nu = (rail.noise.initial if rail.flip_rate is None else noise_for_flip_rate(
        policy, directions(rail.seed, 0, rail.directions, policy.shape.parameter_count), rail.flip_rate, calibration))
    meter = Meter(warmup_rounds=warmup_rounds)
    discriminators = variants(discriminator_settings, rewards, demonstrations.observations)
    backend = build_backend(backend_name, workers, address)
    bar = progress(meter.rollouts(rail), "step signal", unit="rollout")
    with interruptible_run(bar, backend=backend):
        report = measure(policy, config, rail, nu, asked, discriminators,
                         (demonstrations.observations, demonstrations.actions), calibration, backend, meter,
                         on_rollout=lambda index, result: bar.update(_rollouts_in(result)))
        complete(bar)
    record = {**report, "policy": str(policy_path), "zero_weights": zero_weights, "expert": expert,
              "demos": str(demos), "meter": {"warmup_rounds": warmup_rounds},
              "settings": {"rail": dataclasses.asdict(rail),
                           "discriminator": dataclasses.asdict(discriminator_settings)},
              **provenance("step_signal", config, seed)}
    click.echo(signal_table(record))
    if out is not None:
        try:
            write_bytes_atomically(out, json.dumps(record, indent=2, sort_keys=True).encode())
        except OSError as error:
            raise click.ClickException(f"cannot write {out}: {error.strerror or error}") from error
        click.echo(f"wrote {out}")


def _rollouts_in(result: list[Any]) -> int:
    """Rollouts in one task's result: a shared road's (--egos) holds one list of trajectories per member."""
    return len(result) if result and isinstance(result[0], list) else 1


def _estimate(estimate: dict[str, float]) -> str:
    return f"{estimate['value']:+.2f} [{estimate['low']:+.2f}, {estimate['high']:+.2f}]"


def signal_table(record: dict[str, Any]) -> str:
    """The report as Markdown: one row for the agreement and one per discriminator."""
    agreement = record["agreement"]
    lines = [f"nu {record['nu']:.4g}: the perturbations change {record['flip_rate']:.1%} of the policy's decisions on "
             f"the expert's states; {record['decisions']} decisions measured, agreement {record['agreement_mean']:.3f}",
             "", "| return | signal: correlation | signal: step cosine | alignment across draws | alignment within "
             "draws | alignment: step cosine |", "|---|---|---|---|---|---|",
             f"| agreement with the expert | {_estimate(agreement['correlation'])} | "
             f"{_estimate(agreement['step_cosine'])} | | | |"]
    for name, reward in record["rewards"].items():
        signal, alignment = reward["signal"], reward["alignment"]
        lines.append(f"| discriminator: {name} | {_estimate(signal['correlation'])} | "
                     f"{_estimate(signal['step_cosine'])} | {_estimate(alignment['across'])} | "
                     f"{_estimate(alignment['within'])} | {_estimate(alignment['step_cosine'])} |")
    return "\n".join(lines)
