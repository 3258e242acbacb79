"""Options shared by the commands: configuration (defaults, TOML, `--set`), episodes, seeds, workers, backends and
outputs."""

from __future__ import annotations

import contextlib
import signal
import tomllib
from collections.abc import Callable, Iterator
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any

import click
from sumo_rail_cli.progress import progress

from sumo_rail.config import Config, ConfigError

if TYPE_CHECKING:
    from sumo_rail.learning.bc import BcReport
    from sumo_rail.runners.backends import RolloutBackend


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


def imitation_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """--demos, the actor (--policy, --hidden) and its behaviour-cloning initialisation (--bc-epochs,
    --bc-class-balance): what train and gail share."""
    options = [
        click.option("--demos", type=click.Path(path_type=Path, dir_okay=False), required=True,
                     help="Expert demonstrations written by record-expert."),
        click.option("--policy", "kind", type=click.Choice(["linear", "mlp"]), default="mlp", show_default=True,
                     help="linear: obs -> 5 logits; mlp: obs -> --hidden tanh units -> 5 logits."),
        click.option("--hidden", type=click.IntRange(min=1), default=10, show_default=True,
                     help="Hidden units of mlp."),
        click.option("--bc-epochs", type=click.IntRange(min=0), default=20, show_default=True,
                     help="Behaviour-cloning epochs that initialise the policy (0: no BC)."),
        click.option("--bc-class-balance", type=click.FloatRange(min=0), default=0.75, show_default=True,
                     help="Exponent p of BC's class weights (1/frequency)^p: 0 plain cross-entropy, 1 all actions "
                          "equal."),
    ]
    for option in reversed(options):
        command = option(command)
    return command


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


def run_folder_options(step: str, eval_every: int) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """What train and dagger share: --workers and the backend, --seed, validation every `eval_every` of their
    `step`s (iteration, round), the run folder --out and --resume."""
    def decorate(command: Callable[..., Any]) -> Callable[..., Any]:
        options = [
            click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True,
                         help="Worker processes, each running one SUMO; the result does not depend on it."),
            backend_options,
            click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True),
            click.option("--eval-every", type=click.IntRange(min=0), default=eval_every, show_default=True,
                         help=f"Evaluate the policy on validation episodes every this many {step}s and after the "
                              f"last (0: never)."),
            click.option("--eval-episodes", type=click.IntRange(min=1), default=8, show_default=True,
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
    """--backend process|ray and --address (ray only); build the backend with `build_backend`."""
    command = click.option("--address", metavar="auto|HOST:PORT",
                           help="Ray cluster to run on with --backend ray (default: a local Ray with --workers "
                                "CPUs).")(command)
    return click.option("--backend", "backend_name", type=click.Choice(["process", "ray"]), default="process",
                        show_default=True,
                        help="process: worker processes on this machine; ray: Ray actors, locally or on a cluster "
                             "(needs pip install 'sumo-rail[ray]').")(command)


def build_backend(name: str, workers: int, address: str | None) -> RolloutBackend:
    """The backend of --backend/--workers/--address; --address without --backend ray is a usage error (exit 2),
    a missing Ray a one-sentence error (exit 1)."""
    from sumo_rail.runners.factory import make_backend

    if address is not None and name != "ray":
        raise click.UsageError("--address needs --backend ray")
    with library_errors():
        return make_backend(name, workers, address=address)


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
    from sumo_rail.datasets import DatasetError
    from sumo_rail.drivers.policies import PolicyFileError
    from sumo_rail.runners.backends import BackendError
    from sumo_rail.sim.simulation import SimulationError

    try:
        yield
    except (BackendError, DatasetError, PolicyFileError, SimulationError) as error:
        raise click.ClickException(str(error)) from error


def episode_progress(total: int, description: str) -> Any:
    """Progress over episodes on stderr: a live bar with rate and time left on a terminal, a plain line every
    few seconds otherwise (a file, a pipe, a CI log)."""
    return progress(total, description, unit="episode")


def tensorboard_option(command: Callable[..., Any]) -> Callable[..., Any]:
    """--tensorboard DIR: also log every training row to TensorBoard (optional extra)."""
    return click.option("--tensorboard", "tensorboard_dir", type=click.Path(path_type=Path, file_okay=False),
                        default=None, help="Also write TensorBoard logs into this folder (tensorboard --logdir DIR); "
                                           "log.parquet stays the record. Needs pip install "
                                           "'sumo-rail[tensorboard]'.")(command)


@contextlib.contextmanager
def tensorboard_logger(tensorboard_dir: Path | None, prefix: str, run_folder: Path) -> Iterator[Any]:
    """A TensorBoardLogger for --tensorboard (None without it); a missing extra is a one-sentence error (exit 1)."""
    if tensorboard_dir is None:
        yield None
        return
    from sumo_rail.learning.tensorboard_log import TensorBoardError, TensorBoardLogger

    try:
        logger = TensorBoardLogger(tensorboard_dir, prefix, run_folder)
    except TensorBoardError as error:
        raise click.ClickException(str(error)) from error
    try:
        yield logger
    except TensorBoardError as error:
        raise click.ClickException(str(error)) from error
    finally:
        logger.close()


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


def bc_summary(report: BcReport, policy_path: Path) -> str:
    """One line on a behaviour-cloning result: train and held-out accuracy, where the policy was saved."""
    holdout = "n/a" if report.holdout_accuracy is None else f"{report.holdout_accuracy:.3f}"
    return (f"behaviour cloning: train accuracy {report.train_accuracy:.3f}, holdout accuracy {holdout} "
            f"({report.holdout_rows} held-out decisions); saved {policy_path}")


def make_interruptible() -> None:
    """Make SIGINT and SIGTERM raise KeyboardInterrupt, so that both stop a command as Ctrl-C does, even when it was
    started with SIGINT ignored (as a shell script's background jobs are)."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, _raise_keyboard_interrupt)


def _raise_keyboard_interrupt(signal_number: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt
