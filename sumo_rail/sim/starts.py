"""Where an episode starts: the warm traffic state, SUMO's seed and each ego's lane and position, all drawn from the
env's `np_random` at reset, and the reset options that choose the warm state.

The egos' start rule. The single ego starts in a uniformly drawn lane with its front uniformly in the start window
[a, b] = [`env.ego_start_min_m`, `env.ego_start_max_m`]. K egos share that window in K consecutive slots of width
w = (b - a) / K, widened to w = `MIN_SLOT_M` (40 m) when the window is too narrow for them, so that the slots
then reach past b to a + K w (`start_slots`); ego k starts in slot k, ego_0 nearest the start of the road. Each
ego's lane is drawn uniformly and its front uniformly in [a + k w, a + (k + 1) w - `GAP_M`] (the last slot
keeps its whole width, up to b or a + K w), so consecutive egos start at least `GAP_M` (20 m) apart along the road.
With one ego the slot is the window itself: the draws are exactly the single ego's. Pooled over egos, the starts
cover the same window as the single ego's do over episodes (up to the gaps), whenever it is wide enough.

The draws come in this order: the warm state, SUMO's seed, then lane and position of ego_0, ego_1, ... Lanes are
those of the route's first edge. Where no ego finds room at its drawn place (a crowded start), every ego's lane and
position are drawn again in its slot (`EpisodeStarts.redraw`, the next draws), up to `START_DRAWS` places: the
single ego and K egos alike (`WarmStateStart`, the env core's default `StartRule`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any, Protocol

import numpy as np

from sumo_rail.config import Config
from sumo_rail.sim import network
from sumo_rail.sim.ego import CONTEXT_MARGIN_M
from sumo_rail.sim.ego_past import EgoPast
from sumo_rail.sim.simulation import EGO_ID, EgoCouldNotEnter, Simulation
from sumo_rail.sim.warm_states import WARM_STATE_POOLS

_SUMO_SEED_BOUND = 2**31 - 1
START_DRAWS = 20
"""Places tried for the egos' starts before a reset gives up: the road has no room anywhere in the window."""
MIN_SLOT_M = 40.0
"""Narrowest start slot of an ego when several share the road [m]."""
GAP_M = 20.0
"""Least distance between the start positions (fronts) of consecutive egos [m]."""


def start_slots(config: Config, egos: int) -> list[tuple[float, float]]:
    """The interval [m] in which each of `egos` egos starts its front, nearest the start of the road first (see
    the module's docstring); `check_start_slots` says whether they fit on the road."""
    if isinstance(egos, bool) or not (isinstance(egos, int | np.integer) and egos >= 1):
        raise ValueError(f"egos must be an integer >= 1, got {egos!r}")
    low, high = config.env.ego_start_min_m, config.env.ego_start_max_m
    if egos == 1:
        return [(low, high)]
    width = max((high - low) / egos, MIN_SLOT_M)
    high = max(high, low + egos * width)
    return [(low + k * width, low + (k + 1) * width - GAP_M) for k in range(egos - 1)] + \
        [(low + (egos - 1) * width, high)]


def check_start_slots(config: Config, egos: int, road_length_m: float, latest_start_m: float = math.inf) -> None:
    """ValueError when the start slots of `egos` egos reach past the end margin of a road (a route) of
    `road_length_m` [m] (`network.road_length_m`: a user's route's own length) or past `latest_start_m` [m], the
    farthest start that leaves room before a user's route's exit (`network.latest_start_m`)."""
    slots = start_slots(config, egos)
    room = road_length_m - config.env.end_margin_m
    if egos > 1 and slots[-1][1] >= room and slots[-1][1] > config.env.ego_start_max_m:
        raise ValueError(f"{egos} egos need start slots of {MIN_SLOT_M:g} m from {slots[0][0]:g} m to "
                         f"{slots[-1][1]:g} m, past the road's end margin at {room:g} m; use fewer egos or a longer "
                         f"road")
    if egos > 1 and slots[-1][1] > latest_start_m and slots[-1][1] > config.env.ego_start_max_m:
        raise ValueError(f"{egos} egos need start slots of {MIN_SLOT_M:g} m from {slots[0][0]:g} m to "
                         f"{slots[-1][1]:g} m, past {latest_start_m:.0f} m, the farthest start that leaves the ego "
                         f"room to reach its route's exit (docs/scenarios.md); use fewer egos")


@dataclass(frozen=True)
class EpisodeStarts:
    """Everything a reset draws from the env's `np_random` (one ego or several), in the order of the fields."""

    warm_state: int
    sumo_seed: int
    lanes: tuple[int, ...]
    """Each ego's start lane (0 = rightmost)."""
    positions_m: tuple[float, ...]
    """Each ego's start position (its front, from the start of the road) [m]."""

    @classmethod
    def draw(cls, rng: np.random.Generator, config: Config, warm_states: int, egos: int,
             start_lanes: int | None = None) -> EpisodeStarts:
        """Draw the starts; lanes among the `start_lanes` lanes of the route's first edge (default
        scenario.lanes)."""
        slots = start_slots(config, egos)
        warm_state, sumo_seed = int(rng.integers(warm_states)), int(rng.integers(_SUMO_SEED_BOUND))
        return cls(warm_state, sumo_seed, *_places(rng, config, slots, start_lanes))

    def redraw(self, rng: np.random.Generator, config: Config, start_lanes: int | None = None) -> EpisodeStarts:
        """The same warm state and SUMO seed, each ego's lane and position drawn again in its slot (no ego found
        room at its place): the next draws of `rng`, so every driver of the episode's seed gets the same starts."""
        lanes, positions = _places(rng, config, start_slots(config, len(self.lanes)), start_lanes)
        return EpisodeStarts(self.warm_state, self.sumo_seed, lanes, positions)


def _places(rng: np.random.Generator, config: Config, slots: list[tuple[float, float]],
            start_lanes: int | None) -> tuple[tuple[int, ...], tuple[float, ...]]:
    """Each slot's ego's lane and position, drawn in this order (lane, position) slot after slot."""
    lanes, positions = [], []
    for low, high in slots:
        lanes.append(int(rng.integers(start_lanes or config.scenario.lanes)))
        positions.append(float(rng.uniform(low, high)))
    return tuple(lanes), tuple(positions)


def no_room_anywhere(config: Config, egos: int) -> str:
    """What a reset says when no ego found room at `START_DRAWS` places each: the road is too dense."""
    slots = start_slots(config, egos)
    who = "the ego found no room" if egos == 1 else f"none of the {egos} egos found room"
    return (f"{who} at {START_DRAWS} places of {'its' if egos == 1 else 'their'} start window "
            f"({slots[0][0]:g} m to {slots[-1][1]:g} m): traffic is too dense there (scenario.flow_veh_per_h is "
            f"{config.scenario.flow_veh_per_h:g} veh/h)")


RESET_OPTIONS = ("pool", "warm_state")
"""What reset's options may say: the warm-state pool and a fixed warm state (its index in the pool)."""


def warm_state_options(options: dict[str, Any], warm_states: int) -> tuple[str, int | None]:
    """The pool and fixed warm state asked for in reset's options (ValueError on unknown keys or values)."""
    unknown = set(options) - set(RESET_OPTIONS)
    if unknown:
        raise ValueError(f"unknown reset options {sorted(unknown)}; known: 'pool', 'warm_state'")
    pool = options.get("pool", "train")
    if pool not in WARM_STATE_POOLS:
        raise ValueError(f"reset option 'pool' must be one of {', '.join(WARM_STATE_POOLS)}, got {pool!r}")
    warm_state = options.get("warm_state")
    if warm_state is not None and not (isinstance(warm_state, int | np.integer) and 0 <= warm_state < warm_states):
        raise ValueError(f"reset option 'warm_state' must be an integer in [0, {warm_states}), got {warm_state!r}")
    return pool, None if warm_state is None else int(warm_state)


def start_egos(sim: Simulation, rng: np.random.Generator, config: Config, egos: int, options: dict[str, Any],
               enter: Callable[[EpisodeStarts, str], list[str]]) -> list[str]:
    """Reset `sim` for an episode of `egos` egos: draw their starts from `rng` (`EpisodeStarts`, with the warm state
    that reset's `options` fix, if any) and put them on the road with `enter(starts, pool)` (`Simulation.reset_egos`:
    the egos that sit the episode out); where no ego
    found room, every ego's place is drawn again, up to `START_DRAWS` places, then EgoCouldNotEnter. Returns what
    `enter` returned."""
    starts = EpisodeStarts.draw(rng, config, sim.warm_state_count, egos, sim.start_lanes)
    pool, warm_state = warm_state_options(options, sim.warm_state_count)
    if warm_state is not None:
        starts = replace(starts, warm_state=warm_state)
    attempt = 1
    while True:
        try:
            return enter(starts, pool)
        except EgoCouldNotEnter as error:
            if attempt == START_DRAWS:
                raise EgoCouldNotEnter(no_room_anywhere(config, egos)) from error
        attempt += 1
        starts = starts.redraw(rng, config, sim.start_lanes)


def start_ego(sim: Simulation, rng: np.random.Generator, config: Config, options: dict[str, Any]) -> None:
    """What a reset of the single-ego env does to SUMO: reset `sim` with ego `EGO_ID` at its start drawn from `rng`,
    in the warm state and pool that reset's `options` choose (the benchmarks' SUMO-only loop)."""
    WarmStateStart().enter(sim, rng, config, (EGO_ID,), options)


class StartRule(Protocol):
    """How the env core (`ParallelHighwayEnv`) starts an episode: its simulation (and so its traffic,
    `sumo_rail.sim.traffic_source`), the egos' entry and what is known of them before it. `WarmStateStart` for the
    generated roads and users' networks; `sumo_rail.recordings.seat.SeatStart` puts the ego in a recorded vehicle's
    seat."""

    @property
    def options(self) -> tuple[str, ...]:
        """The reset options it reads (the env ignores others, with a warning)."""
        ...

    def simulation(self, config: Config, transport: str, gui: bool, gui_delay_ms: float) -> Simulation:
        """The env's simulation, made at its first reset."""
        ...

    def enter(self, sim: Simulation, rng: np.random.Generator, config: Config, agents: Sequence[str],
              options: dict[str, Any]) -> list[str]:
        """Reset `sim` with the egos `agents` (their SUMO ids) on the road, drawing from `rng`; the agents that sit
        the episode out."""
        ...

    def past(self, sim: Simulation, agent: str) -> EgoPast | None:
        """What is known of the ego `agent` before its first decision (its observation's history block), or None."""
        ...


@dataclass(frozen=True)
class WarmStateStart:
    """Episodes from warm traffic states: the state, SUMO's seed and each ego's place drawn by `start_egos`."""

    options: tuple[str, ...] = RESET_OPTIONS

    def simulation(self, config: Config, transport: str, gui: bool, gui_delay_ms: float) -> Simulation:
        network.check_user_route(config)
        return Simulation(config.scenario, config.lidar.range_m + CONTEXT_MARGIN_M, gui=gui, transport=transport,
                          gui_delay_ms=gui_delay_ms)

    def enter(self, sim: Simulation, rng: np.random.Generator, config: Config, agents: Sequence[str],
              options: dict[str, Any]) -> list[str]:
        return start_egos(sim, rng, config, len(agents), options, lambda starts, pool: sim.reset_egos(
            starts.warm_state, starts.sumo_seed, list(zip(agents, starts.lanes, starts.positions_m, strict=True)),
            pool))

    def past(self, sim: Simulation, agent: str) -> EgoPast | None:
        return None  # an ego placed from a warm state has no past before it
