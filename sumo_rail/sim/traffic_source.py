"""Where a simulation's traffic comes from: a part the env core takes, as it takes the egos' start rule and
controllers. `GeneratedTraffic` (the default): the road's own flows, episodes starting from their warm states;
`sumo_rail.sim.replay.ReplayedTraffic`: a recorded scene's vehicles, replayed or reactive. A source says which
network and routes SUMO runs and what each SUMO step of the egos' periods does besides SUMO's own models.
"""

from __future__ import annotations

from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any, Protocol

from sumo_rail.config import ScenarioConfig
from sumo_rail.sim import network
from sumo_rail.sim.built_network import BuiltNetwork

Step = Callable[[], Any]
"""One SUMO step."""


class TrafficSource(Protocol):
    """The traffic of one `Simulation` (stateful: one source per simulation)."""

    def network(self, scenario: ScenarioConfig) -> BuiltNetwork:
        """The network and routes SUMO runs for `scenario` (asked once, before SUMO starts)."""
        ...

    def connect(self, api: Any, step_s: float, speed_limit_mps: float) -> Step | None:
        """SUMO has started over `api` (steps of `step_s` [s], the road's limit `speed_limit_mps` [m/s]): the step each
        SUMO step of the egos' periods takes (None: SUMO's own)."""
        ...

    @property
    def collided(self) -> Collection[str]:
        """Egos this source saw collide in the episode, which SUMO may still answer for (SUMO's own collision lists
        say the rest)."""
        ...

    def check_warm_start(self) -> None:
        """SimulationError when this traffic's episodes do not start from warm states (`Simulation.reset_egos`)."""
        ...


@dataclass(frozen=True)
class GeneratedTraffic:
    """The routes' own flows, driven by SUMO alone, episodes starting from their warm states (`warm_states`): the
    generated roads' and a user's network's traffic, or, with `built`, a network and routes made elsewhere (SUMO's
    drivers recorded as a scene)."""

    built: BuiltNetwork | None = None

    def network(self, scenario: ScenarioConfig) -> BuiltNetwork:
        return self.built or network.build(scenario)

    def connect(self, api: Any, step_s: float, speed_limit_mps: float) -> Step | None:
        return None

    @property
    def collided(self) -> Collection[str]:
        return ()

    def check_warm_start(self) -> None:
        return None
