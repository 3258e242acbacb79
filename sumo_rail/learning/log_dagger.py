"""DAgger's rounds against the log (`dagger --expert log` on demonstrations read from a recorded scene by
`recorded-demos`): the learner drives in the seats of that scene's train-split cars (`recordings.seat.SceneEnv`, the
other vehicles replayed as recorded) and every state it visits is labelled by `log_teacher.log_label` from the seated
car's own recorded track.

Each round draws `episodes_per_round` seats (`evaluation.scene_evaluation.choose_seats` of the train split, the ego
seated `seat_lead_s` into the track for `seat_s`) by the run's seed and the round; a decision is the teacher's label
with probability beta, else the policy's (DAgger's mixture, as with a queryable expert).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from sumo_rail.config import Config
from sumo_rail.drivers.policies import Policy
from sumo_rail.learning.log_teacher import HumanTrack, log_label, read_human_track
from sumo_rail.learning.mixture import LabelledEpisode, Mixture
from sumo_rail.learning.train_seats import SceneSeatsError, SeatNames, TrainSeats, seat_env
from sumo_rail.recordings.acceleration_reading import smoothing_for
from sumo_rail.recordings.actions import ActionRule
from sumo_rail.recordings.scene_observations import SceneRoad, in_route_frame, route_from, scene_road, scene_routes
from sumo_rail.recordings.seats import Seat
from sumo_rail.runners.backends import RolloutBackend, WorkerContext
from sumo_rail.runners.rollout import run_episode
from sumo_rail.sim.traffic import TrafficView

LOG_TEACHER = "log"
"""DAgger's expert that means the log (`dagger --expert log`)."""


class LogTeacherError(SceneSeatsError):
    """Training against the log cannot run with this configuration."""


LOG_SEATS = SeatNames("--expert log trains against the log of", "dagger.seat_lead_s", "dagger.seat_s",
                      "dagger.seat_zone_m")


@dataclass(frozen=True)
class LogDaggerTask:
    """One labelled episode in one seat: the mixture of `policy` and the log teacher (probability `beta`) drives; the
    states and labels are kept (an empty episode when the ego never reached a labelled state)."""

    config: Config
    policy: Policy
    seat: Seat
    human: HumanTrack
    horizon_s: float
    beta: float
    seed: int

    def run(self, context: WorkerContext) -> LabelledEpisode:
        env = seat_env(context, self.config, self.seat)
        teacher = _Teacher(self.human, self.seat.start_s, self.horizon_s, env.config)
        mixture = Mixture(self.policy, teacher, self.beta, self.seed)
        run_episode(env, mixture, self.seed, options={"vehicle": self.seat.vehicle, "start_s": self.seat.start_s})
        return mixture.episode()


class _Teacher:
    """`log_label` at each decision of a seat's episode, the k-th at start_s + k T [s]."""

    def __init__(self, human: HumanTrack, start_s: float, horizon_s: float, config: Config) -> None:
        self.human, self.start_s, self.horizon_s, self.config = human, start_s, horizon_s, config
        self.decisions = 0

    def __call__(self, observation: np.ndarray, traffic: TrafficView) -> int | None:
        time_s = self.start_s + self.decisions * self.config.env.decision_period_s
        self.decisions += 1
        ego = traffic.ego
        return log_label(time_s, ego.lane_position_m, ego.speed_mps, ego.lane, self.human, self.horizon_s,
                         self.config.actions)


def seat_frame(road: SceneRoad, track: pd.DataFrame, recorded: tuple[str, ...], start_s: float) -> pd.DataFrame:
    """A seated car's rows (sorted by time; it drove the edges `recorded`) in the route frame of the seated ego, whose
    positions and lanes the teacher compares with them: its recorded edges from the one it is on at `start_s` [s]
    (in a junction, the one before), as `sim.replay` gives the ego; the rows before it reached that route left out."""
    before = track.loc[track["time_s"] <= start_s + 1e-9, "edge"].astype(str)
    edges = before[~before.str.startswith(":")]
    framed = in_route_frame(road, track, route_from(recorded, edges.iloc[-1]) if len(edges) else recorded)
    return framed[np.isfinite(framed["lane_position_m"].to_numpy(dtype=float))]


@dataclass(frozen=True)
class LogSeats:
    """The train-split seats of the scene a run learns against, with their cars' tracks read for the teacher."""

    train: TrainSeats
    humans: tuple[HumanTrack, ...]
    horizon_s: float

    @property
    def config(self) -> Config:
        """The run's configuration with the seat's length as env.max_episode_s."""
        return self.train.config

    @property
    def seats(self) -> tuple[Seat, ...]:
        return self.train.seats

    @classmethod
    def of(cls, metadata: Mapping[str, Any], demos: str, config: Config, seat_lead_s: float, seat_s: float,
           horizon_s: float, zone_m: float = 0.0) -> LogSeats:
        """The train-split seats of the scene the demonstrations `demos` (their `metadata`) were read from
        (`TrainSeats.of`); a LogTeacherError (one sentence) when the interface is not the acceleration interface, a
        SceneSeatsError when the demonstrations are not a scene's, the scene changed since or has no seat that long."""
        if config.actions.interface != "acceleration":
            raise LogTeacherError(f"training against the log labels accelerations, so it needs --set "
                                  f"actions.interface=acceleration (this run's is {config.actions.interface!r})")
        train = TrainSeats.of(metadata, demos, config, seat_lead_s, seat_s, zone_m, LOG_SEATS)
        scene = train.scene
        rule, smoothing_s = ActionRule.for_env(train.config.env), smoothing_for(scene.meta.format)
        road, routes = scene_road(scene.network), scene_routes(scene.tracks)
        humans = [read_human_track(seat_frame(road, scene.track(seat.vehicle).sort_values("time_s", kind="stable"),
                                              routes[seat.vehicle], seat.start_s), rule, train.config.actions,
                                   smoothing_s, road.sideways_sign(routes[seat.vehicle]))
                  for seat in train.seats]
        return cls(train, tuple(humans), horizon_s)

    def round_episodes(self, backend: RolloutBackend, policy: Policy, beta: float, seed: int, round_: int,
                       episodes: int, on_episode: Callable[[int, Any], None] | None = None) -> list[LabelledEpisode]:
        """A round's labelled episodes: `episodes` seats drawn by (`seed`, `round_`) (`TrainSeats.draw`), each with
        its own episode seed (episodes without a labelled state left out)."""
        labelled = backend.run([LogDaggerTask(self.config, policy, self.seats[index], self.humans[index],
                                              self.horizon_s, beta, episode_seed)
                                for index, episode_seed in self.train.draw(episodes, (seed, round_))],
                               on_result=on_episode)
        return [episode for episode in labelled if len(episode.labels)]
