"""`ParallelHighwayEnv`: the env core, K controlled egos on one SUMO road (K = 1 the plain case), as a PettingZoo
`ParallelEnv` (`sumo_rail.parallel_env(egos=K, config=...)`). The Gymnasium env `HighwayEnv` is its adapter for one
ego; every episode of the project, of one ego or K, starts, steps and ends here.

Agents `ego_0` ... `ego_{K-1}` (or the names given as `egos`) are SUMO vehicles of the same ids and the ego type.
Each is driven by the rules of `sumo_rail.sim.ego.Ego` (actions, observation, rewards, info and metrics) and
sees the other egos as traffic (they are vehicles within its LIDAR and context radius). Every decision runs one
decision period of the shared simulation for all egos still driving, so a decision of K egos costs about one
simulation period plus K observations (`Simulation.advance_egos`, for one ego as for K: a loop of its own for one ego
saved nothing measurable, docs/benchmarks.md "One ego").

Starts (`start`, a `sumo_rail.sim.starts.StartRule`; a recorded scene's is `sumo_rail.recordings.seat.SeatStart`).
By default (`WarmStateStart`) each reset draws, from the env's `np_random`, the warm state, SUMO's seed, then each
ego's lane and position by the start-slot rule of `sumo_rail.sim.starts` (evenly spaced slots in the single ego's
start window, ego_0 nearest the start of the road, widened past it when K slots of 40 m do not fit). The episode
starts once every ego is on the road (those that entered first drive on meanwhile); an ego that finds no room at its
place within 30 s of simulated time (a dense left lane; 2 of 2400 egos in 150 resets at K = 16 on the default
scenario) sits the episode out: `agents` after `reset` lacks it and it makes no decision (`Simulation.reset_egos`).
When no ego enters (always so for a single ego that finds no room), every ego's place is drawn again
(`EpisodeStarts.redraw`). `reset(options=...)` takes the start rule's options (by default "pool" and "warm_state")
and "controller", who drives the egos in the episode (`sumo_rail.sim.controllers`: "actions", the default, or "sumo",
SUMO's own models; one name for every ego, or a mapping of agents to names, "actions" for those it leaves out);
others are ignored with a warning (PettingZoo's API test passes one). The traffic is the start rule's simulation's
(`sumo_rail.sim.traffic_source`).

Ends: an ego that collides (terminated; SUMO removes the vehicles of a collision, two egos that collide both end)
or reaches the end of the road (truncated) leaves `agents` while the others drive on; an ego truncated within the
end margin drives on under SUMO's control as traffic for those behind it, until it leaves the network. All egos
start together, so the time limit truncates every ego still driving at the same decision; the episode ends when
`agents` is empty.

Rendering: `render_mode="rgb_array"` makes `render()` the bird's-eye frame of the first ego's last decision (of
the first that entered, when ego_0 sat the episode out; `frame(agent)` draws any ego's); `"human"` drives SUMO in
sumo-gui (traci), following the first ego, with `gui_delay_ms` [ms] of wall time per SUMO step.

Respawns: `respawn(agent)` starts a new episode of an ego that has left while the others drive on (a new vehicle
placed at once in the start window), for runners and learners that keep every ego busy
(`sumo_rail.sim.respawning`).

For a rollout runner: before each `step`, `traffic(agent)` is that ego's `TrafficView` (so an expert can be asked
at every decision), and `metrics(agent)` its episode totals (`decisions` is its number of steps); `infos[agent]`
carries `Ego`'s info keys. Watching episodes: `watching(observer)` (`sumo_rail.sim.observers`) shows an observer
every SUMO step of the egos' periods, or each reset and decision (with what each ego decided on and did).
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo import ParallelEnv

from sumo_rail.config import Config
from sumo_rail.sim import network
from sumo_rail.sim.actions import action_space_of
from sumo_rail.sim.controllers import ActionController, Controller, controllers_of
from sumo_rail.sim.ego import Ego, checked_action, edge_rows
from sumo_rail.sim.observation import observation_space
from sumo_rail.sim.observers import Moment, Observer, WatchedObserver
from sumo_rail.sim.rewards import EpisodeMetrics
from sumo_rail.sim.simulation import TRANSPORTS, Simulation, SimulationError
from sumo_rail.sim.starts import StartRule, WarmStateStart, check_start_slots, start_slots
from sumo_rail.sim.traffic import TrafficView

if TYPE_CHECKING:
    from sumo_rail.sim.ego_frame import EgoFrames

RENDER_MODES = ("human", "rgb_array")
"""human: sumo-gui (needs a display); rgb_array: `render()` returns a bird's-eye frame (no display needed)."""

RESPAWN_DRAWS = 100
"""Most places `ParallelHighwayEnv.respawn` tries in the start window, then as many again from the road's start to
the window's end, before it gives up."""
Observations = dict[str, np.ndarray]


class NoRoomToRespawn(SimulationError):
    """No safe place for a respawning ego: the egos (or traffic) fill the road's start, e.g. a one-lane ramp."""

Infos = dict[str, dict[str, Any]]


class ParallelHighwayEnv(ParallelEnv[str, np.ndarray, np.int64]):
    """`egos` egos (a number, or the agents' names) on the highway of `config`, in one SUMO over `transport`:
    libsumo (in-process, fast; one simulation per process) or traci (a `sumo` process over a socket); "auto", the
    default, takes libsumo unless another env of this process holds it, then traci; render_mode "human" (sumo-gui)
    implies traci. `start` says how episodes start (default `WarmStateStart()`)."""

    metadata = {"name": "sumo_rail_highway_v0", "render_modes": list(RENDER_MODES),  # noqa: RUF012
                "is_parallelizable": True}

    def __init__(self, egos: int | Sequence[str] = 1, config: Config | Mapping[str, Any] | str | Path | None = None,
                 transport: str = "auto", render_mode: str | None = None, gui_delay_ms: float = 100.0,
                 start: StartRule | None = None) -> None:
        if transport not in TRANSPORTS:
            raise ValueError(f"transport must be one of {', '.join(TRANSPORTS)}, got {transport!r}")
        if render_mode not in (None, *RENDER_MODES):
            raise ValueError(f"render_mode must be None, 'human' (sumo-gui) or 'rgb_array', got {render_mode!r}")
        if not (isinstance(gui_delay_ms, int | float) and gui_delay_ms >= 0):
            raise ValueError(f"gui_delay_ms must be a number of milliseconds >= 0, got {gui_delay_ms!r}")
        names = [f"ego_{k}" for k in range(egos)] if isinstance(egos, int) and egos >= 1 else egos
        if isinstance(names, str) or not (isinstance(names, Sequence) and names and len(set(names)) == len(names)
                                          and all(isinstance(name, str) and name for name in names)):
            raise ValueError(f"egos must be an integer >= 1 or distinct agent names, got {egos!r}")
        self.config = Config.coerce(config)
        if len(names) > 1:
            check_start_slots(self.config, len(names), network.road_length_m(self.config),
                              network.latest_start_m(self.config))
        self.slots = start_slots(self.config, len(names))
        """Start interval of each ego's front [m] (`sumo_rail.sim.starts.start_slots`)."""
        self.transport = transport
        self.render_mode = render_mode
        self.gui_delay_ms = float(gui_delay_ms)
        self.start = start or WarmStateStart()
        self.possible_agents = list(names)
        self.agents: list[str] = []
        self.observation_spaces = {agent: observation_space(self.config) for agent in self.possible_agents}
        self.action_spaces = {agent: action_space_of(self.config.actions) for agent in self.possible_agents}
        self._steps_per_decision = self.config.env.steps_per_decision(self.config.scenario.step_length_s)
        self._np_random: np.random.Generator | None = None
        self._sim: Simulation | None = None
        self._edges: np.ndarray | None = None
        self._egos: dict[str, Ego] = {}
        self._respawns: dict[str, int] = {}
        self._frames: EgoFrames | None = None
        self._controllers: dict[str, Controller] = dict.fromkeys(self.possible_agents, ActionController())
        """Who drives each ego in this episode (reset's option "controller")."""
        self._observers: list[Observer] = []
        """Reset and decision observers (`watching`)."""

    @property
    def options(self) -> tuple[str, ...]:
        """The reset options it reads: its start rule's and "controller"."""
        return (*self.start.options, "controller")

    def observation_space(self, agent: str) -> spaces.Box:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Discrete:
        return self.action_spaces[agent]

    @property
    def np_random(self) -> np.random.Generator:
        """The generator every reset draws from (seeded by `reset(seed=...)`, as a Gymnasium env's)."""
        if self._np_random is None:
            self._np_random, _ = seeding.np_random()
        return self._np_random

    @np_random.setter
    def np_random(self, generator: np.random.Generator) -> None:
        self._np_random = generator

    @property
    def started(self) -> bool:
        """An episode has begun (a reset since the env was made; its egos stay readable after `close`)."""
        return bool(self._egos)

    @property
    def simulation(self) -> Simulation | None:
        """The SUMO simulation (None before the first reset and after `close`)."""
        return self._sim

    def traffic(self, agent: str) -> TrafficView:
        """`agent`'s view of the traffic at its last decision (read from SUMO, not from the LIDAR)."""
        view = self._ego(agent).traffic
        if view is None:
            raise RuntimeError(f"{agent} could not enter the road in this episode (see `reset`)")
        return view

    def metrics(self, agent: str) -> EpisodeMetrics:
        """`agent`'s totals of the current episode (they stay readable after it has left `agents`)."""
        return self._ego(agent).metrics

    def _ego(self, agent: str) -> Ego:
        if agent not in self._egos:
            if agent in self.possible_agents:
                raise RuntimeError("call reset() before reading an ego")
            raise KeyError(f"no agent {agent!r}; agents are {', '.join(self.possible_agents)}")
        return self._egos[agent]

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Observations, Infos]:
        if seed is not None:
            self._np_random, _ = seeding.np_random(seed)
        cfg, rule = self.config, self.start
        options = dict(options or {})
        unknown = sorted(set(options) - set(self.options))
        if unknown:
            warnings.warn(f"ignored unknown reset options {unknown}; known: {', '.join(self.options)}",
                          stacklevel=2)
        controllers = controllers_of(options.get("controller", ActionController.name), self.possible_agents)
        if self._sim is None:
            self._sim = rule.simulation(cfg, self.transport, self.render_mode == "human", self.gui_delay_ms)
            for observer in self._observers:
                if observer.every_step:
                    self._sim.watch(observer)
        sim = self._sim
        absent = rule.enter(sim, self.np_random, cfg, self.possible_agents,
                            {key: options[key] for key in rule.options if key in options})
        if self._edges is None:
            self._edges = edge_rows(sim)
        self._egos = {agent: Ego(cfg, agent, self._edges, rule.past(sim, agent)) for agent in self.possible_agents}
        self._respawns = dict.fromkeys(self.possible_agents, 0)
        self.agents = [agent for agent in self.possible_agents if agent not in absent]
        observations, infos = {}, {}
        for agent in self.agents:
            observations[agent], infos[agent] = self._egos[agent].start(sim)
        self._controllers = controllers
        for agent in self.agents:
            controllers[agent].take(sim, self._egos[agent])
        if self._observers:
            self._tell(Moment(sim.time_s, "reset", sim.vehicle_rows, infos=infos))
        return observations, infos

    def step(self, actions: dict[str, Any]) -> tuple[Observations, dict[str, float], dict[str, bool],
                                                     dict[str, bool], Infos]:
        """One decision of every ego in `agents` (`actions` has exactly their actions); returns their outcomes,
        and those that terminated or were truncated leave `agents`."""
        if self._sim is None or not self.agents:
            raise RuntimeError("call reset() before step()" if self._sim is None or not self._egos
                               else "every ego has left the road; call reset()")
        if set(actions) != set(self.agents):
            missing, extra = sorted(set(self.agents) - set(actions)), sorted(set(actions) - set(self.agents))
            raise ValueError(f"actions must be given for exactly the agents still driving, {self.agents}; "
                             f"missing {missing}, not driving {extra}")
        chosen = {agent: checked_action(actions[agent], self.action_spaces[agent]) for agent in self.agents}
        sim, egos, controllers = self._sim, [self._egos[agent] for agent in self.agents], self._controllers
        seen = {agent: (ego.last_observation, self.traffic(agent))  # what each ego decides on, for the observers
                for agent, ego in zip(self.agents, egos, strict=True)} if self._observers else {}
        for agent, ego in zip(self.agents, egos, strict=True):
            controllers[agent].command(sim, ego, chosen[agent])
        reports = sim.advance_egos(self._steps_per_decision, [ego.vehicle for ego in egos],
                                   [vehicle for ego in egos for vehicle in ego.period_safety.watched()])
        observations, rewards, terminations, truncations, infos = {}, {}, {}, {}, {}
        for agent, ego, report in zip(self.agents, egos, reports, strict=True):
            (observations[agent], rewards[agent], terminations[agent], truncations[agent],
             infos[agent]) = ego.finish(sim, report)
        self.agents = [agent for agent in self.agents if not (terminations[agent] or truncations[agent])]
        if self._observers:
            self._tell(Moment(sim.time_s, "decision", sim.vehicle_rows, chosen, infos, seen))
        return observations, rewards, terminations, truncations, infos

    @contextlib.contextmanager
    def watching(self, observer: WatchedObserver) -> Iterator[WatchedObserver]:
        """`observer` is shown every SUMO step of the egos' periods (every_step) or each reset and decision, within
        the block (`sumo_rail.sim.observers`)."""
        self._observers.append(observer)
        if observer.every_step and self._sim is not None:
            self._sim.watch(observer)
        try:
            yield observer
        finally:
            self._observers.remove(observer)
            if observer.every_step and self._sim is not None:
                self._sim.unwatch(observer)

    def _tell(self, moment: Moment) -> None:
        """Show the reset and decision observers `moment`."""
        for observer in self._observers:
            if not observer.every_step:
                observer(moment)

    def respawn(self, agent: str) -> tuple[np.ndarray, dict[str, Any]]:
        """Start a new episode of `agent`, which is not driving (it ended, or sat the episode out), while the others
        drive on: a new SUMO vehicle (id AGENT.N at its N-th respawn since the reset) is placed at once
        (`Simulation.place_ego`) in a lane and at a front position drawn from `np_random` as the single ego's start
        (uniform lane, uniform in the start window), redrawn up to `RESPAWN_DRAWS` times until the place is safe;
        when the egos have jammed the start window (slow learners do), up to `RESPAWN_DRAWS` more draws from the
        road's start (one ego length in) to the window's end. `agent` rejoins `agents`; returns its first
        observation and info. NoRoomToRespawn when no draw is safe (the ego stays off the road; it may try again after
        a step or a reset)."""
        if self._sim is None or not self._egos:
            raise RuntimeError("call reset() before respawn()")
        self._ego(agent)
        if agent in self.agents:
            raise ValueError(f"{agent} is driving; only an ego that has left the road can respawn")
        cfg, sim = self.config, self._sim
        self._respawns[agent] += 1
        vehicle = f"{agent}.{self._respawns[agent]}"
        windows = ((cfg.env.ego_start_min_m, cfg.env.ego_start_max_m), (sim.ego_length_m, cfg.env.ego_start_max_m))
        for low_m, high_m in (window for window in windows for _ in range(RESPAWN_DRAWS)):
            lane = int(self.np_random.integers(sim.start_lanes))
            position_m = float(self.np_random.uniform(low_m, high_m))
            if sim.place_ego(vehicle, lane, position_m, cfg.env.v_max_mps):
                break
        else:
            raise NoRoomToRespawn(f"no safe place for {agent} to respawn in {2 * RESPAWN_DRAWS} draws up to "
                                  f"{cfg.env.ego_start_max_m:g} m: traffic is too dense there (scenario."
                                  f"flow_veh_per_h is {cfg.scenario.flow_veh_per_h:g} veh/h)")
        assert self._edges is not None  # read at the first reset
        ego = self._egos[agent] = Ego(cfg, vehicle, self._edges)
        self.agents = [name for name in self.possible_agents if name in self.agents or name == agent]
        started = ego.start(sim)
        self._controllers[agent].take(sim, ego)
        return started

    def render(self) -> np.ndarray | None:
        """With render_mode "rgb_array", the frame of the first ego's last decision (`frame`; of the first ego that
        entered the road, when ego_0 sat the episode out); with "human", sumo-gui draws by itself and this returns
        None."""
        if self.render_mode != "rgb_array":
            return None
        return self.frame(next((agent for agent, ego in self._egos.items() if ego.traffic is not None), None))

    def frame(self, agent: str | None = None) -> np.ndarray:
        """A bird's-eye RGB frame (H, W, 3) uint8 of `agent`'s last decision (default: the first ego), whatever the
        render mode (`sumo_rail.sim.ego_frame.EgoFrames.draw`)."""
        from sumo_rail.sim.ego_frame import EgoFrames

        if self._sim is None or not self._egos:
            raise RuntimeError("call reset() before render()")
        agent = agent or self.possible_agents[0]
        if self._ego(agent).traffic is None:
            raise RuntimeError(f"{agent} could not enter the road in this episode (see `reset`)")
        if self._frames is None:
            self._frames = EgoFrames(self.config)
        return self._frames.draw(self._sim, self._ego(agent))

    def gui_screenshot(self, path: str | Path, width_px: int = 1280, height_px: int = 800) -> None:
        """With render_mode "human": save sumo-gui's view as a PNG at `path` when the next step is drawn."""
        if self._sim is None:
            raise RuntimeError("call reset() before gui_screenshot()")
        self._sim.screenshot(Path(path), width_px, height_px)

    def close(self) -> None:
        if self._sim is not None:
            self._sim.close()
            self._sim = None
        self.agents = []
