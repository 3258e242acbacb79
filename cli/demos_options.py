"""Which demonstrations an imitation command (train, dagger, gail) learns from: --include-failed-demos and
--demos-from-other-road, checked against the run's road before any work."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

if TYPE_CHECKING:
    from sumo_rail.config import Config


def demos_selection_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """--include-failed-demos and --demos-from-other-road."""
    command = click.option("--demos-from-other-road", "other_road", is_flag=True,
                           help="Learn from demonstrations recorded on another road (scenario.kind) than this run's.")(
        command)
    return click.option("--include-failed-demos", "include_failed", is_flag=True,
                        help="Learn from the demonstrations' failed episodes too (a collision, a missed exit, a stop "
                             "at a lane's end); without it they are left out.")(command)


RECORDED_NOTE = ("note: these demonstrations are recorded drivers': behaviour cloning's accuracies are agreement "
                 "with their read actions; agreement with the expert (validation lines, the log) asks the rule-based "
                 "normal style, which says nothing about them; judge the policy in their seats with evaluate-scene")
"""What a learner on recorded demonstrations prints first: what its printed numbers measure."""


def check_demos(demos: Path, config: Config, include_failed: bool, other_road: bool) -> bool:
    """Refuse (exit 2, one sentence) demonstrations of another action interface, recorded on another road without
    `other_road`, whose
    observations have another size because their road has another lane count, or read from a recorded scene whose
    road's speed limit this configuration does not keep; say how many failed episodes are left out. Whether they
    were read from a recorded scene (`RECORDED_NOTE` says what that means for the printed numbers). A file that
    cannot be read is left to the learner to report."""
    from sumo_rail.datasets import DatasetError, read_metadata
    from sumo_rail.recordings.scene import check_speed_limit
    from sumo_rail.runners.experts import RECORDED_SCENE
    from sumo_rail.runners.tables import failed_episodes, interface_mismatch
    from sumo_rail.sim.observation import observation_space

    try:
        metadata = read_metadata(demos)
        left_out = 0 if include_failed else len(failed_episodes(demos))
    except (DatasetError, OSError, ValueError):
        return False
    recorded = (metadata.get("config") or {}).get("scenario") or {}
    kind, lanes = recorded.get("kind", config.scenario.kind), recorded.get("lanes", config.scenario.lanes)
    if kind != config.scenario.kind and not other_road:
        raise click.BadParameter(f"{demos} were recorded on the {kind} road, this run drives on "
                                 f"{config.scenario.kind}: record demonstrations on this road, or pass "
                                 f"--demos-from-other-road to learn from them anyway", param_hint="'--demos'")
    size, names = observation_space(config).shape[0], metadata.get("observation_names")
    if lanes != config.scenario.lanes and isinstance(names, list) and len(names) != size:
        raise click.BadParameter(f"{demos} were recorded on a road of {lanes} lanes, this run's has "
                                 f"{config.scenario.lanes}, so their observations have {len(names)} values, not "
                                 f"{size}: record demonstrations with this lane count", param_hint="'--demos'")
    try:
        interface_mismatch(demos, metadata, config.actions)
    except DatasetError as error:
        raise click.BadParameter(str(error), param_hint="'--demos'") from error
    scene = metadata.get(RECORDED_SCENE)
    if isinstance(scene, dict) and isinstance(scene.get("speed_limit_mps"), float):
        try:
            check_speed_limit(scene["speed_limit_mps"], config, f"the road of the scene {demos} were read from")
        except DatasetError as error:
            raise click.BadParameter(str(error), param_hint="'--demos'") from error
    if left_out:
        click.echo(f"left out {left_out} failed demonstration episode{'s' * (left_out != 1)} (a collision or a "
                   f"route failure); pass --include-failed-demos to learn from them")
    return isinstance(scene, dict)
