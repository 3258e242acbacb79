"""The command `evaluate-scene`: drivers in held-out recorded drivers' seats, closed loop (docs/replay.md)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from .evaluation_options import (
    check_video_dir,
    evaluation_backend,
    parse_drivers,
    video_option,
    write_videos,
)
from .options import backend_options, check_output, output_options, seed_option
from .param_types import FiniteFloat
from .progress import complete, progress
from .running import interruptible_run
from .settings import config_options

if TYPE_CHECKING:
    from sumo_rail.config import Config
    from sumo_rail.recordings.idm_calibration import IdmCalibration


@click.command("evaluate-scene")
@config_options
@click.argument("scenes", nargs=-1, required=True, type=click.Path(path_type=Path, file_okay=False))
@click.option("--policy", "policies", multiple=True, default=("expert",), show_default=True,
              metavar="expert[:STYLE]|keep|sumo-idm|sumo-idm-calibrated|PATH",
              help="Driver in the seats (repeatable): the rule-based expert, keep (a constant set-point, the human's "
                   "speed at the start), sumo-idm (SUMO's IDM and LC2013 drive the ego), sumo-idm-calibrated (the "
                   "same with the IDM fitted on each scene's train split and the desired speed read from the seated "
                   "driver's lead-in) or a saved policy file.")
@click.option("--split", type=click.Choice(["test", "validation"]), default="test", show_default=True,
              help="Whose seats: the scenes' held-out vehicles of this split (of --seat-class).")
@click.option("--seat-class", "classes", multiple=True, type=click.Choice(["passenger", "truck"]),
              default=("passenger",), show_default=True,
              help="The recorded vehicles' classes whose seats are taken (repeatable); the ego takes the seat's "
                   "class and size.")
@click.option("--mode", "modes", multiple=True, type=click.Choice(["non-reactive", "reactive"]),
              default=("non-reactive", "reactive"), show_default=True,
              help="non-reactive: the other vehicles replayed as recorded; reactive: driven by SUMO from their "
                   "recorded state, each by its recorded vType or else the IDM calibrated on the scene's train split "
                   "(repeatable).")
@click.option("--horizon-s", type=FiniteFloat(1, 600), default=15.0, show_default=True,
              help="Length of each episode [s] (the position error is read at 1, 2, 5, 10, 15 and 20 s, within it); "
                   "it is the seats' env.max_episode_s (another value set for it is refused).")
@click.option("--lead-s", type=FiniteFloat(0, 600), default=5.0, show_default=True,
              help="The ego takes the seat this long after the vehicle's track begins [s].")
@click.option("--zone-m", type=FiniteFloat(0, 100_000), default=0.0, show_default=True,
              help="Seats where traffic is established: each starts at the first instant after --lead-s at which the "
                   "car is at least this far along the road [m], and its horizon ends at least this far before the "
                   "road's end (cars that never fit are left out; 0: every seat --lead-s into its track).")
@click.option("--seats", "limit", type=click.IntRange(min=1), default=None,
              help="Seats per scene, drawn by --seed  [default: every seat that fits].")
@seed_option("Seed of the seats' draw and of each episode's SUMO seed.")
@backend_options
@video_option("every episode, named DRIVER_MODE_episodeNNN_seedS.mp4 (NNN: the seat's index; choose how "
              "many with --seats)")
@output_options(required=False)
def evaluate_scene_command(config: Config, scenes: tuple[Path, ...], policies: tuple[str, ...], split: str,
                           classes: tuple[str, ...], modes: tuple[str, ...], horizon_s: float, lead_s: float,
                           zone_m: float, limit: int | None, seed: int, workers: int, backend_name: str,
                           address: str | None, video_dir: Path | None, out: Path | None, overwrite: bool) -> None:
    """Put each driver in the seat of each held-out recorded car (or truck, --seat-class truck) of SCENES (folders of
    import-recording or record-sumo-drivers) for --horizon-s, and measure it against that vehicle's recorded track:
    position error at 1, 2, 5, 10, 15 and 20 s (those the episode reaches), RMSE of position and speed, collisions and
    those the ego caused, stops, progress relative to the human, lane changes per km, hard braking, TTC below 1.5 s,
    the driving score, and the distances of its speed, acceleration, jerk, gap and time-headway distributions to the
    humans'. --out gets one row per episode and NAME.tracks.parquet beside it one row per decision (the humans' own
    rows under the driver "human"). --video films every episode into a folder."""
    from sumo_rail.config import EnvConfig
    from sumo_rail.datasets import DatasetError
    from sumo_rail.evaluation.evaluate import DEFAULT_REFERENCE
    from sumo_rail.evaluation.protocol import summarise, unique_names, write_evaluation
    from sumo_rail.evaluation.scene_evaluation import (
        CALIBRATED_IDM,
        SEAT_DRIVERS,
        calibrated_idm_driver,
        evaluate_seats,
        tracks_path,
    )
    from sumo_rail.recordings.scene import check_scene, read_scene, scene_sources
    from sumo_rail.recordings.scene_drivers import reactive_types
    from sumo_rail.recordings.seats import choose_seats
    from sumo_rail.recordings.tracks import RecordingUsageError

    check_output(out, overwrite)
    if out is not None:
        check_output(tracks_path(out), overwrite)
    if config.env.max_episode_s not in (EnvConfig().max_episode_s, horizon_s):
        raise click.UsageError(f"a seat's episode lasts --horizon-s ({horizon_s:g} s), env.max_episode_s "
                               f"({config.env.max_episode_s:g} s) would be ignored: pass --horizon-s "
                               f"{config.env.max_episode_s:g} instead")
    config = config.with_overrides({"env": {"max_episode_s": horizon_s}})
    try:
        read = [read_scene(scene) for scene in scenes]
        for scene in read:
            check_scene(scene, config, split)  # a network whose main road has the observation's lanes
        seats = [seat for scene in read for seat in choose_seats(scene, split, horizon_s, lead_s, limit, seed,
                                                                          zone_m=zone_m, classes=classes,
                                                                          earliest_s=config.scenario.step_length_s)]
    except RecordingUsageError as error:
        raise click.UsageError(str(error)) from error
    except DatasetError as error:  # a scene file there but damaged: data, not usage (as recorded-demos says it)
        raise click.ClickException(str(error)) from error
    if not seats:
        zone = f" --zone-m {zone_m:g} m past the road's start and before its end" if zone_m > 0 else ""
        raise click.UsageError(f"no {split} vehicle ({', '.join(classes)}) of {', '.join(map(str, scenes))} has a "
                               f"track of --lead-s + --horizon-s = {lead_s + horizon_s:g} s{zone}")
    step_s, named = config.scenario.step_length_s, dict(SEAT_DRIVERS)
    calibrations: dict[str, IdmCalibration] = {}
    if CALIBRATED_IDM in policies:
        try:
            named[CALIBRATED_IDM], calibrations = calibrated_idm_driver(read, step_s, lead_s, horizon_s, seats)
        except ValueError as error:
            raise click.BadParameter(str(error), param_hint="'--policy'") from error
    drivers = parse_drivers(policies, config, DEFAULT_REFERENCE, named, [CALIBRATED_IDM])
    reactive = {str(scene.folder): reactive_types(scene, step_s) for scene in read} if "reactive" in modes else {}
    names = unique_names(drivers)
    check_video_dir(video_dir, [f"{name} {mode}" for name in names for mode in modes], overwrite)  # held
    backend = evaluation_backend(backend_name, workers, address)
    bar = progress(len(drivers) * len(seats) * len(modes), "driving in recorded seats")
    with interruptible_run(bar, backend=backend):
        evaluation = evaluate_seats(drivers, names, config, seats, modes, backend, seed,
                                    on_episode=lambda index, result: bar.update(),
                                    reactive_types={folder: found.types for folder, found in reactive.items()},
                                    video_episodes=len(seats) if video_dir is not None else 0)
        if out is not None:
            write_evaluation(evaluation, config, seed, out,
                             scenes={str(scene.folder.resolve()): scene_sources(scene) for scene in read},
                             policies=list(policies), split=split, seat_classes=list(classes), seats=limit,
                             lead_s=lead_s, zone_m=zone_m,
                             idm_calibration={folder: found.as_dict() for folder, found in calibrations.items()},
                             reactive_drivers={folder: found.as_dict() for folder, found in reactive.items()})
        written_videos = write_videos(evaluation.videos, video_dir)
        complete(bar)
    click.echo(f"{len(seats)} seats of {len(read)} scene(s), {horizon_s:g} s each\n")
    for folder, found in calibrations.items():
        click.echo(f"{folder}, {CALIBRATED_IDM}: {found.describe()}\n")
    for folder, drove in reactive.items():
        click.echo(f"{folder}, {drove.describe()}\n")
    click.echo(summarise(evaluation, config))
    if out is not None:
        click.echo(f"wrote {out}: {len(evaluation.metrics)} episodes; {tracks_path(out)}: {len(evaluation.decisions)} "
                   f"decisions")
    if written_videos:
        click.echo(f"wrote {len(written_videos)} videos into {video_dir}: {', '.join(written_videos)}")
