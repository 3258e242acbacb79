"""Who drives each ego: a part the env core takes (reset option "controller", `CONTROLLERS`, for every ego or ego by
ego), as it takes its traffic and start rule. "actions" (the default): the env's actions, whoever chooses them (a
learner, the expert, a policy); "sumo": SUMO's own models (IDM car following, LC2013 lane changing), the actions
passed to `step` checked and counted, not used: the baseline of a recorded seat (`evaluate-scene`'s sumo-idm). The
option may also give a controller itself, such as a `SumoController` of another vehicle type and desired speed
(`evaluate-scene`'s sumo-idm-calibrated).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol, cast

from sumo_rail.sim.ego import Ego
from sumo_rail.sim.simulation import Simulation

SUMO_DRIVER_TYPE = "scene_idm"
"""The vehicle type of an ego SUMO drives: IDM car following, LC2013 lane changing, SUMO's default parameters (a type
of a recorded scene's routes, `sumo_rail.sim.replay`)."""


class Controller(Protocol):
    """Drives one ego of the env core over an episode."""

    @property
    def name(self) -> str:
        """The name reset's option "controller" takes."""
        ...

    def take(self, sim: Simulation, ego: Ego) -> None:
        """Take the ego's vehicle, after its first observation."""
        ...

    def command(self, sim: Simulation, ego: Ego, action: int) -> None:
        """This decision's command (`action` checked by the env), before the period's steps."""
        ...


@dataclass(frozen=True)
class ActionController:
    """The env's actions drive the ego (`Ego.command`: set-point or acceleration, lane-change requests)."""

    name: str = "actions"

    def take(self, sim: Simulation, ego: Ego) -> None:
        return None

    def command(self, sim: Simulation, ego: Ego, action: int) -> None:
        ego.command(sim, action)


@dataclass(frozen=True)
class SumoController:
    """SUMO's own models drive the ego: vehicle type `type_id` (a type of the simulation's routes; by default
    `SUMO_DRIVER_TYPE`), desired speed `desired_mps` [m/s] (by default the ego's top set-point); the decisions are
    counted, the actions not used."""

    name: str = "sumo"
    type_id: str = SUMO_DRIVER_TYPE
    desired_mps: float | None = None

    def take(self, sim: Simulation, ego: Ego) -> None:
        sim.hand_to_sumo(ego.vehicle, self.type_id,
                         ego.top_speed_mps(sim) if self.desired_mps is None else self.desired_mps)

    def command(self, sim: Simulation, ego: Ego, action: int) -> None:
        ego.metrics.decisions += 1


CONTROLLERS: dict[str, Controller] = {controller.name: controller for controller in (ActionController(),
                                                                                     SumoController())}
"""The controllers by the name reset's option "controller" takes."""


def controllers_of(option: object, agents: Sequence[str]) -> dict[str, Controller]:
    """Each of `agents`' controller as reset's option "controller" says: one name (or controller) for every agent, or
    a mapping of agents to them ("actions" for those it leaves out); ValueError naming the known ones, or the agents,
    otherwise."""
    names = option if isinstance(option, Mapping) else dict.fromkeys(agents, option)
    strangers = sorted(map(str, set(names) - set(agents)))
    if strangers:
        raise ValueError(f"reset option 'controller' names no agent {strangers[0]!r}; agents are {', '.join(agents)}")
    wrong = [name for name in names.values()
             if not (isinstance(name, (ActionController, SumoController)) or (isinstance(name, str)
                                                                              and name in CONTROLLERS))]
    if wrong:
        raise ValueError(f"reset option 'controller' must be one of {', '.join(map(repr, CONTROLLERS))} or a "
                         f"controller (or a mapping of agents to them), got {wrong[0]!r}")
    chosen = {agent: names.get(agent, ActionController.name) for agent in agents}
    return {agent: CONTROLLERS[value] if isinstance(value, str) else cast(Controller, value)
            for agent, value in chosen.items()}
