"""What `evaluate` and `evaluate-scene` share: their --policy words read as drivers, and the backend their episodes
run on (in this process for one worker)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import click

from .options import build_backend

if TYPE_CHECKING:
    from sumo_rail.config import Config
    from sumo_rail.runners.backends import RolloutBackend
    from sumo_rail.runners.rollout import DriverSpec


def parse_drivers(policies: tuple[str, ...], config: Config, expert: DriverSpec,
                  named: Mapping[str, DriverSpec] | None = None) -> list[DriverSpec]:
    """Each --policy word's driver (`protocol.parse_driver`; `named`: the drivers named by a word, default any road's):
    a policy file that cannot be read is an error (exit 1), any other bad word a bad --policy (exit 2)."""
    from sumo_rail.drivers.policies import PolicyFileError
    from sumo_rail.evaluation.protocol import NAMED_DRIVERS, parse_driver

    drivers = []
    for text in policies:
        try:
            drivers.append(parse_driver(text, config, expert, NAMED_DRIVERS if named is None else named))
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
