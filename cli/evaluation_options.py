"""What `evaluate` and `evaluate-scene` share: their --policy words read as drivers, the backend their episodes run on
(in this process for one worker), and watching them (--gui in sumo-gui, --video MP4s)."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from .options import build_backend
from .output_lock import lock_output
from .param_types import FiniteFloat

if TYPE_CHECKING:
    from sumo_rail.config import Config
    from sumo_rail.runners.backends import RolloutBackend
    from sumo_rail.runners.rollout import DriverSpec


def parse_drivers(policies: tuple[str, ...], config: Config, expert: DriverSpec,
                  named: Mapping[str, DriverSpec] | None = None, words: Sequence[str] = ()) -> list[DriverSpec]:
    """Each --policy word's driver (`protocol.parse_driver`; `named`: the drivers named by a word, default any road's;
    `words`: more valid words, listed when a word is bad): a policy file there that cannot be read is an error
    (exit 1), any other bad word (a path with nothing there, a policy file of another action interface) a bad
    --policy (exit 2)."""
    from sumo_rail.drivers.policies import PolicyFileError, PolicyInterfaceError
    from sumo_rail.evaluation.protocol import NAMED_DRIVERS, parse_driver

    drivers = []
    for text in policies:
        try:
            drivers.append(parse_driver(text, config, expert, NAMED_DRIVERS if named is None else named, words))
        except PolicyInterfaceError as error:
            raise click.BadParameter(str(error), param_hint="'--policy'") from error
        except PolicyFileError as error:
            raise click.ClickException(str(error)) from error
        except ValueError as error:
            raise click.BadParameter(str(error), param_hint="'--policy'") from error
    return drivers


def evaluation_backend(backend_name: str, workers: int, address: str | None, gui: bool = False,
                       gui_delay_ms: float | None = None) -> RolloutBackend:
    """The backend of --backend/--workers/--address (`build_backend`), but this process for one worker (no worker
    for one) and for --gui (sumo-gui here, `gui_delay_ms` [ms] per 0.1 s step, default 100: real time)."""
    from sumo_rail.runners.backends import SerialBackend

    if gui or (workers == 1 and backend_name == "process" and address is None):
        return SerialBackend(render_mode="human" if gui else None,
                             gui_delay_ms=100.0 if gui_delay_ms is None else gui_delay_ms)
    return build_backend(backend_name, workers, address)


def video_option(what: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """--video DIR: a folder for MP4s of `what` (e.g. "every episode")."""
    return click.option("--video", "video_dir", type=click.Path(path_type=Path, file_okay=False), default=None,
                        help=f"Folder for MP4 videos (bird's-eye view, one frame per decision) of {what}; needs pip "
                             f"install 'sumo-rail[video]'.")


def watching_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """--gui/--gui-off, --gui-delay, --video and --video-episodes (evaluate's)."""
    options: list[Callable[[Callable[..., Any]], Callable[..., Any]]] = [
        click.option("--gui/--gui-off", default=False, show_default=True,
                     help="--gui drives the first episode of the first driver in sumo-gui (needs a display), "
                          "following the ego (drawn in red)."),
        click.option("--gui-delay", "gui_delay_ms", type=FiniteFloat(min=0), default=None, metavar="MS",
                     help="With --gui: wall-clock milliseconds per 0.1 s SUMO step  [default: 100, real time; 0: as "
                          "fast as possible]."),
        video_option("the first --video-episodes episodes of every driver"),
        click.option("--video-episodes", type=click.IntRange(min=1), default=None, metavar="K",
                     help="With --video: episodes recorded per driver  [default: 1]."),
    ]
    for option in reversed(options):
        command = option(command)
    return command


def check_watching(gui: bool, gui_delay_ms: float | None, video_dir: Path | None, video_episodes: int | None) -> None:
    """Usage errors of the watching options (exit 2)."""
    if gui_delay_ms is not None and not gui:
        raise click.UsageError("--gui-delay needs --gui")
    if video_episodes is not None and video_dir is None:
        raise click.UsageError("--video-episodes needs --video DIR")


def check_video_dir(video_dir: Path | None, names: list[str], overwrite: bool) -> None:
    """Check --video before any work: the encoder is installed (exit 1, with the install hint), the folder can be
    made, and no video of these drivers would be replaced without --overwrite (exit 2); then hold it as an output
    (`lock_output`: another command filming into it is exit 1)."""
    if video_dir is None:
        return
    from sumo_rail.datasets import file_in_the_way
    from sumo_rail.runners.video import VideoError, require_encoder, video_name

    try:
        require_encoder()
    except VideoError as error:
        raise click.ClickException(str(error)) from error
    if video_dir.exists() and not video_dir.is_dir():
        raise click.BadParameter(f"{video_dir} exists and is not a folder", param_hint="'--video'")
    if not video_dir.exists() and not video_dir.parent.is_dir():
        blocking = file_in_the_way(video_dir.parent)
        raise click.BadParameter(f"the folder holding {video_dir} does not exist" if blocking is None else
                                 f"the folder holding {video_dir} cannot be: {blocking} is a file, not a folder",
                                 param_hint="'--video'")
    if video_dir.is_dir() and not overwrite:
        prefixes = {video_name(name, 0, 0).split("_episode")[0] for name in names}
        clash = sorted(path.name for path in video_dir.glob("*.mp4") if path.name.split("_episode")[0] in prefixes)
        if clash:
            raise click.BadParameter(f"{video_dir} already holds videos of these drivers ({clash[0]}, ...); pass "
                                     f"--overwrite to replace them", param_hint="'--video'")
    lock_output(video_dir, "--video")


def write_videos(videos: dict[str, bytes], video_dir: Path | None) -> list[str]:
    """Write each video into --video atomically; the file names, sorted."""
    if video_dir is None:
        return []
    from sumo_rail.runners.video import VideoError, write_bytes

    try:
        video_dir.mkdir(exist_ok=True)
        for name, content in videos.items():
            write_bytes(content, video_dir / name)
    except (OSError, VideoError) as error:
        raise click.ClickException(f"cannot write the videos into {video_dir}: {error}") from error
    return sorted(videos)
