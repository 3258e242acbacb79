"""`sumo-rail`: the click command group. Commands are thin: options -> config -> library call -> summary."""

from __future__ import annotations

import logging

import click

from .running import begin_command, end_quietly_while_starting, make_interruptible, stopped

end_quietly_while_starting()  # first: Ctrl-C and SIGTERM in the slow imports below (libsumo, scipy) and click's parsing
from .commands import evaluate_command, record_expert, train_command
from .dagger_command import dagger_command
from .export_command import export_minari_command
from .gail_command import gail_command
from .import_command import import_recording_command
from .ppo_command import ppo_command
from .recordings_commands import record_sumo_drivers_command, recorded_demos_command
from .report_command import report_command
from .scene_command import evaluate_scene_command
from .signal_command import step_signal_command


class _Commands(click.Group):
    """The command group: a Ctrl-C or SIGTERM outside a command's work (in its checks, after the work) is one
    sentence saying which of its outputs were written (`stopped`), exit 1, as one during the work is."""

    def invoke(self, ctx: click.Context) -> object:
        try:
            begin_command()
            make_interruptible()  # the command's own: its work turns a stop into its own sentence
            return super().invoke(ctx)
        except KeyboardInterrupt:
            raise click.ClickException(stopped()) from None


@click.group(cls=_Commands, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="sumo-rail", prog_name="sumo-rail")
@click.option("-v", "--verbose", is_flag=True, help="Log progress details to stderr.")
def cli(verbose: bool) -> None:
    """Imitation learning of highway driving decisions (RAIL) in SUMO.

    The pipeline: record-expert records the expert (a rule-based style, or a policy such as one ppo trains from
    the env's reward); train (RAIL), dagger or gail learn from it; evaluate compares
    the policies with the expert on held-out episodes; report plots runs and evaluations. Each command's --help is
    its full reference; --preset recommended gives the benchmark's setting (default: the paper's)."""
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING, format="%(levelname)s %(message)s")


cli.add_command(record_expert)
cli.add_command(evaluate_command)
cli.add_command(train_command)
cli.add_command(gail_command)
cli.add_command(dagger_command)
cli.add_command(ppo_command)
cli.add_command(report_command)
cli.add_command(export_minari_command)
cli.add_command(step_signal_command)
cli.add_command(import_recording_command)
cli.add_command(record_sumo_drivers_command)
cli.add_command(recorded_demos_command)
cli.add_command(evaluate_scene_command)

