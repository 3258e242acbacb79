"""RAIL's rollouts in recorded seats (`rail.rollout_seats` = S > 0): on demonstrations read from a recorded scene
(recorded-demos), each rollout drives S seats of that scene's train split (`learning.train_seats`), one episode of
env.max_episode_s each, the other vehicles replayed as recorded; its return is the mean over them.

Direction k's S seats and their episode seeds are drawn by (the run's seed, the iteration, k) (with
`rail.common_traffic`, one draw by (seed, iteration) for every direction), so theta + nu delta_k and theta - nu delta_k
drive the very same seats from the very same states (the antithetic pair differs by its sign only), and the draw does
not depend on how many workers run the rollouts.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sumo_rail.config import Config
from sumo_rail.learning.rail.iteration import Perturbations, RailSettings, Trajectory, asking, trajectories_of
from sumo_rail.learning.train_seats import SeatNames, TrainSeats, seat_env
from sumo_rail.recordings.seats import Seat
from sumo_rail.runners.rollout import DriverSpec, run_episode
from sumo_rail.sim.observation import observation_space

if TYPE_CHECKING:
    from sumo_rail.drivers.policies import Policy
    from sumo_rail.runners.backends import RolloutBackend, WorkerContext

RAIL_SEATS = SeatNames("rail.rollout_seats drives RAIL's rollouts in the train-split seats of", "rail.seat_lead_s",
                       "env.max_episode_s", "rail.seat_zone_m")


def rail_seats(settings: RailSettings, metadata: Mapping[str, Any], demos: str | Path,
               config: Config) -> InSeats | None:
    """The train-split seats RAIL's rollouts drive (`settings.rollout_seats` > 0), each env.max_episode_s long, else
    None; a `train_seats.SceneSeatsError` (one sentence) when the demonstrations `demos` (their `metadata`) are not a
    scene's, or the scene cannot be read, changed since or has no such seat."""
    if not settings.rollout_seats:
        return None
    return InSeats(TrainSeats.of(metadata, demos, config, settings.seat_lead_s, config.env.max_episode_s,
                                 settings.seat_zone_m, RAIL_SEATS))


@dataclass(frozen=True)
class SeatRolloutTask(Perturbations):
    """One rollout in recorded seats: theta + sign * nu * delta(iteration, index) drives each seat in turn, one
    episode each, seeded by its episode seed."""

    member: tuple[int, int]
    """(index, sign)."""
    nu: float
    seats: tuple[Seat, ...]
    episode_seeds: tuple[int, ...]
    expert: DriverSpec | None = None
    """Asked at every decision what it would do (it never drives); its answers come back as `expert_actions`."""

    def run(self, context: WorkerContext) -> list[list[Trajectory]]:
        """The rollout's trajectories, one per seat, as the one member of `RolloutTask.run`'s answer."""
        policy = self.perturbed(*self.member, self.nu)
        trajectories: list[Trajectory] = []
        for seat, seed in zip(self.seats, self.episode_seeds, strict=True):
            env = seat_env(context, self.config, seat)
            labels: list[int] = []
            driver = asking(policy, None if self.expert is None else self.expert.create(self.config, seed), labels)
            result = run_episode(env, driver, seed, record=True,
                                 options={"vehicle": seat.vehicle, "start_s": seat.start_s})
            trajectories.extend(trajectories_of([result], labels if self.expert is not None else None,
                                                observation_space(self.config).shape[0]))
        return [trajectories]


@dataclass(frozen=True)
class InSeats:
    """RAIL's rollouts in `seats` (`iteration.SeatRollouts`)."""

    seats: TrainSeats

    def __call__(self, policy: Policy, settings: RailSettings, iteration: int, nu: float, expert: DriverSpec | None,
                 backend: RolloutBackend, on_rollout: Callable[[int, Any], None] | None) -> list[list[Trajectory]]:
        """The 2N rollouts of theta +- nu delta_k, in the order (0, +), (0, -), (1, +), ...: both signs of direction
        k on the seats and episode seeds drawn for k (module docstring); `on_rollout(index, rollouts)` as each
        arrives."""
        seats, count, seed = self.seats, settings.rollout_seats, settings.seed
        common = seats.draw(count, (seed, iteration)) if settings.common_traffic else None
        tasks: list[SeatRolloutTask] = []
        for k in range(settings.directions):
            drawn = common if common is not None else seats.draw(count, (seed, iteration, k))
            chosen, episode_seeds = tuple(seats.seats[i] for i, _ in drawn), tuple(s for _, s in drawn)
            tasks.extend(SeatRolloutTask(seats.config, policy.shape, policy.parameters, policy.observation_mean,
                                         policy.observation_std, seed, iteration, (k, sign), nu, chosen,
                                         episode_seeds, expert)
                         for sign in (1, -1))
        return [rollout for result in backend.run(tasks, on_result=on_rollout) for rollout in result]
