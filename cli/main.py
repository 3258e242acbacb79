"""`sumo-rail`: the click command group. Commands are thin: options -> config -> library call -> summary."""

from __future__ import annotations

import logging

import click
import numpy as np
from sumo_rail_cli.options import config_options, resolve_config
from tqdm import tqdm

from sumo_rail.episode import DRIVERS, run_episode
from sumo_rail.sim import SimulationError


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="sumo-rail", prog_name="sumo-rail")
@click.option("-v", "--verbose", is_flag=True, help="Log progress details to stderr.")
def cli(verbose: bool) -> None:
    """Imitation learning of highway driving decisions (RAIL) in SUMO."""
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING, format="%(levelname)s %(message)s")


@cli.command("run-episode")
@config_options
@click.option("--driver", type=click.Choice(sorted(DRIVERS)), default="keep", show_default=True,
              help="Built-in driver: 'keep' never acts, 'random' picks uniformly random actions.")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Seed of the first episode.")
@click.option("--episodes", type=click.IntRange(min=1), default=1, show_default=True, help="Episodes to run.")
def run_episode_command(config_path, overrides, driver: str, seed: int, episodes: int) -> None:
    """Drive episodes on the highway and print their metrics (headless)."""
    config = resolve_config(config_path, overrides)
    from sumo_rail.env import HighwayEnv

    env = HighwayEnv(config)
    rows = []
    try:
        for episode in tqdm(range(episodes), desc="episodes", unit="ep", disable=episodes == 1):
            rows.append(run_episode(env, DRIVERS[driver], seed + episode))
    except SimulationError as error:
        raise click.ClickException(str(error)) from error
    finally:
        env.close()
    _print_metrics(driver, rows)


def _print_metrics(driver: str, rows: list[dict[str, float | int | str]]) -> None:
    keys = [key for key in rows[0] if key not in ("seed", "termination")]
    click.echo(f"driver {driver}: {len(rows)} episode(s), seeds {rows[0]['seed']}..{rows[-1]['seed']}, "
               f"ended by {', '.join(sorted({str(r['termination']) for r in rows}))}")
    for key in keys:
        values = np.array([float(r[key]) for r in rows])
        click.echo(f"  {key:<24} {values.mean():>10.2f}" + (f" +- {values.std():.2f}" if len(rows) > 1 else ""))
