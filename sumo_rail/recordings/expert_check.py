"""The check that a scene gives the env's own observation: drive the rule-based expert in the env (record-expert's
rollout, `run_episode`), capture every vehicle of the simulation at each decision instant, write the capture as SUMO
FCD, import it (`import_recording`, on the env's network), compute the ego's observation at each instant from the
scene (`recorded_demos.decisions_table`) and compare it with the observation the env gave.

The comparison takes the env's own cruise set-point (decoded from its observation): a recorded track has none, and
`recorded-demos` estimates it; `ObservationCheck.set_point_error_mps` says how far that estimate is from the
expert's. Differences come from FCD's two decimals (positions, speeds, angles) and nothing else is expected.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from sumo_rail.config import Config
from sumo_rail.recordings import fcd
from sumo_rail.recordings.actions import ActionRule
from sumo_rail.recordings.importing import ImportSettings, check_import, import_recording
from sumo_rail.recordings.recorded_demos import TrackDecisions, decisions_table, track_decisions
from sumo_rail.recordings.scene import check_scene, read_scene
from sumo_rail.runners.rollout import EpisodeResult, ExpertDriver, run_episode
from sumo_rail.sim import network
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.observation import observation_names
from sumo_rail.sim.observers import VehicleCapture
from sumo_rail.sim.sumo_api import EGO_ID


@dataclass(frozen=True)
class ObservationCheck:
    """The scene's observations against the env's at the same instants."""

    decisions: int
    max_abs_difference: float
    """Largest absolute difference over every entry of every compared observation."""
    worst_entries: dict[str, float]
    """The entries whose largest difference exceeds 1e-6, by name."""
    set_point_error_mps: float
    """Largest difference [m/s] between the action rule's estimated set-point and the expert's."""
    lane_changing: int
    """Compared decisions at which the env saw a lane change under way."""


def expert_episode(config: Config, seed: int, style: str = "normal") -> tuple[EpisodeResult, pd.DataFrame]:
    """One recorded episode of the expert `style` (seed `seed`) and every vehicle at each of its decision instants
    (`scene.TRACK_COLUMNS`, as SUMO's FCD output sees them, and `observers.ROW_FIELDS`' type)."""
    env = HighwayEnv(config, transport="libsumo")
    try:
        with env.watching(VehicleCapture(every_step=False)) as capture:
            result = run_episode(env, ExpertDriver(style).create(config, seed), seed, record=True)
    finally:
        env.close()
    return result, pd.DataFrame(capture.columns).drop(columns="frame")


def check_observations(config: Config, seed: int, folder: Path, decimals: int = 2) -> ObservationCheck:
    """Drive one expert episode, write its vehicles as FCD with `decimals` decimals (SUMO's default 2) into
    `folder`, import them as the scene `folder/scene` and compare the ego's observations computed from it with the
    env's."""
    result, rows = expert_episode(config, seed)
    assert result.steps is not None
    fcd_file = fcd.write(rows, folder / "episode.fcd.xml", decimals)
    settings = ImportSettings("fcd", (fcd_file,), folder / "scene", network=network.build(config.scenario).net_file,
                              test_share=0.0, validation_share=0.0)
    import_recording(settings, config, check_import(settings))
    scene = read_scene(folder / "scene")
    road = check_scene(scene, config, "train")
    track = scene.tracks[scene.tracks["vehicle_id"] == EGO_ID].sort_values("time_s")
    env_observations = result.steps["observation"]
    decisions = min(len(track) - 1, len(env_observations))
    names = observation_names(config)
    set_point_at = names.index("cruise_set_point")
    env_set_points = (config.env.v_min_mps + env_observations[:decisions, set_point_at].astype(np.float64)
                      * (config.env.v_max_mps - config.env.v_min_mps))
    instants = track["time_s"].to_numpy()[:decisions]
    decided = TrackDecisions(EGO_ID, instants, result.steps["action"][:decisions],
                             np.append(env_set_points, env_set_points[-1]), np.zeros(decisions), track)
    _, observations = decisions_table(scene, road, config, [decided], len(names))
    difference = np.abs(observations.astype(np.float64) - env_observations[:decisions].astype(np.float64))
    worst = difference.max(axis=0)
    estimated = track_decisions(EGO_ID, track, ActionRule.for_env(config.env), config).set_points_mps
    count = min(len(estimated) - 1, decisions)
    return ObservationCheck(decisions, float(difference.max()),
                            {names[index]: float(worst[index]) for index in np.flatnonzero(worst > 1e-6)},
                            float(np.abs(estimated[:count] - env_set_points[:count]).max()),
                            int(env_observations[:decisions, names.index("lane_change_in_progress")].sum()))


def check_in_scratch(config: Config, seed: int, decimals: int = 2) -> ObservationCheck:
    """`check_observations` in a scratch folder."""
    with tempfile.TemporaryDirectory() as scratch:
        return check_observations(config, seed, Path(scratch), decimals)
