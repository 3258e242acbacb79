"""The `[actions]` settings: which action interface the ego is driven through, and the acceleration interface's
range and bins (`sumo_rail.sim.actions` turns an action into SUMO's commands)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from sumo_rail.bounds import ConfigError, bounded

INTERFACES = ("paper", "acceleration")
"""paper: the paper's five actions (keep, accelerate, decelerate: the ACC's set-point moved by env.speed_step_mps;
lane left, lane right). acceleration: a longitudinal acceleration bin and a lane keep / left / right."""

DECODINGS = ("argmax", "expected", "median")
"""How a policy's logits become an action (`sumo_rail.drivers.decoding`). argmax: the action of the highest logit.
expected and median (the acceleration interface only): the lane decision of the highest lateral marginal (the
softmax summed over its bins), then the bin nearest the mean, or the median, of the acceleration under the softmax
conditioned on that lane decision."""


@dataclass(frozen=True)
class ActionConfig:
    """How the ego is driven. The default is the paper's interface; "acceleration" is the interface that can say
    what a human driver does: the ego's longitudinal acceleration for the next decision period [m/s^2], in bins of
    `acceleration_bin_mps2` from `acceleration_min_mps2` to `acceleration_max_mps2`, and a lane change (keep, left,
    right). Under it SUMO's Krauss safe speed remains the emergency brake: a commanded acceleration never drives the
    ego into its leader, and the ego's speed is capped only by its vehicle type's top speed (55 m/s), not the road's
    limit."""

    interface: str = "paper"
    """The action interface: "paper" (five actions on the ACC's set-point) or "acceleration" (an acceleration bin
    and keep / lane left / lane right in one integer, bin + bins x lane decision: the action space Discrete(3 x
    bins), 111 actions at the default bins)."""
    acceleration_min_mps2: float = bounded(-9, 0, "m/s^2", default=-6.0, high_open=True)
    """The lowest acceleration of the acceleration interface [m/s^2], at least -9 and below 0 m/s^2 (-9: SUMO's
    emergency deceleration). The default covers the hardest braking of highD's and NGSIM's drivers (about -6)."""
    acceleration_max_mps2: float = bounded(0, 5, "m/s^2", default=3.0, low_open=True)
    """The highest acceleration of the acceleration interface [m/s^2], above 0 and at most 5 m/s^2. The default
    covers highD's and NGSIM's drivers (about +3 m/s^2)."""
    acceleration_bin_mps2: float = bounded(0.05, 0.25, "m/s^2", default=0.25)
    """The width of the acceleration interface's bins [m/s^2], between 0.05 and 0.25 m/s^2; it divides the range from
    acceleration_min_mps2 to acceleration_max_mps2 into whole bins (37 at the defaults)."""
    decoding: str = "argmax"
    """How a policy's logits become its action in this run (training, validation and evaluation alike; a policy file
    records the decoding it was trained with): "argmax" (the highest logit), or on the acceleration interface
    "expected" (the lane decision of the highest lateral marginal, then the bin nearest the acceleration's mean under
    the softmax given that lane decision) or "median" (that distribution's median bin). A classifier's argmax takes
    the modal bin (0 m/s^2) where a driver gently speeds up; the mean does not."""
    sampling_temperature: float = bounded(0, 1, default=1.0, low_open=True)
    """The temperature of a policy that draws its actions (`--policy sampled:PATH`), above 0 and at most 1: it draws
    from the softmax of its logits divided by this. 1 draws from the softmax itself; lower values draw nearer the
    argmax (a classifier trained on noisy labels, sampled, spreads its actions wider than the labels it learned)."""

    def validate(self) -> None:
        if self.interface not in INTERFACES:
            raise ConfigError(f"unknown actions.interface {self.interface!r}; known: {', '.join(INTERFACES)}")
        bins = (self.acceleration_max_mps2 - self.acceleration_min_mps2) / self.acceleration_bin_mps2
        if abs(bins - round(bins)) > 1e-6:
            raise ConfigError(f"actions.acceleration_bin_mps2 ({self.acceleration_bin_mps2:g} m/s^2) must divide the "
                              f"range from {self.acceleration_min_mps2:g} to {self.acceleration_max_mps2:g} m/s^2 "
                              f"into whole bins")
        if self.decoding not in DECODINGS:
            raise ConfigError(f"unknown actions.decoding {self.decoding!r}; known: {', '.join(DECODINGS)}")
        if self.decoding != "argmax" and self.interface != "acceleration":
            raise ConfigError(f"actions.decoding={self.decoding} reads a lane decision and an acceleration bin off the "
                              f"acceleration interface's logits; the {self.interface} interface's actions are decoded "
                              f"by argmax (set actions.interface=acceleration)")

    def same_space(self, other: ActionConfig) -> bool:
        """Whether `other` is the same interface with the same actions (its decoding may differ)."""
        return dataclasses.replace(other, decoding=self.decoding) == self

    @property
    def acceleration_bins(self) -> int:
        """The number of acceleration values of the acceleration interface (the range's ends included)."""
        return round((self.acceleration_max_mps2 - self.acceleration_min_mps2) / self.acceleration_bin_mps2) + 1

    def acceleration_mps2(self, index: int) -> float:
        """The acceleration [m/s^2] of bin `index` (0 the lowest)."""
        return self.acceleration_min_mps2 + index * self.acceleration_bin_mps2

    def nearest_bin(self, acceleration_mps2: float) -> int:
        """The bin whose acceleration is nearest `acceleration_mps2` [m/s^2], clipped to the range."""
        index = round((acceleration_mps2 - self.acceleration_min_mps2) / self.acceleration_bin_mps2)
        return min(max(index, 0), self.acceleration_bins - 1)
