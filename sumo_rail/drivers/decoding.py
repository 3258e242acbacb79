"""How a policy's logits become an action (`actions.decoding`, `sumo_rail.action_config.DECODINGS`).

argmax: the action of the highest logit (ties: the lowest index), on either interface. On the acceleration interface,
whose action is lateral x bins + bin (`sim.actions.acceleration_action`), "expected" and "median" read the softmax of
the logits as a distribution over (lane decision, acceleration bin): the lane decision is the argmax of its marginal
(the probabilities summed over its bins; ties: keep, then left), then the acceleration is read off the distribution of
the bins conditioned on that decision: "expected" its mean snapped to the nearest bin (the bins are evenly spaced,
so the mean acceleration's nearest bin is the mean bin index rounded, halves to even as `ActionConfig.nearest_bin`),
"median" the lowest bin whose conditional cumulative probability reaches 1/2. Both are deterministic.
"""

from __future__ import annotations

import numpy as np

from sumo_rail.action_config import DECODINGS
from sumo_rail.sim.actions import Lateral

LATERALS = len(Lateral)
"""Lane decisions of the acceleration interface (keep, left, right), the slow axis of its actions."""


def check_decoding(decoding: str, actions: int) -> None:
    """A ValueError, one sentence, when a policy of `actions` actions cannot be decoded by `decoding`."""
    if decoding not in DECODINGS:
        raise ValueError(f"unknown decoding {decoding!r}; known: {', '.join(DECODINGS)}")
    if decoding != "argmax" and (actions % LATERALS or actions < LATERALS):
        raise ValueError(f"the {decoding} decoding reads a lane decision x acceleration bin (the acceleration "
                         f"interface's actions); a policy of {actions} actions is decoded by argmax")


def decode(logits: np.ndarray, decoding: str) -> np.ndarray:
    """The action of each row of `logits` (shape (..., actions)) under `decoding`, an integer array of shape (...)."""
    logits = np.asarray(logits, dtype=np.float64)
    if decoding == "argmax":
        return np.argmax(logits, axis=-1)
    bins = logits.shape[-1] // LATERALS
    probabilities = np.exp(logits - logits.max(axis=-1, keepdims=True))
    probabilities = probabilities.reshape(*logits.shape[:-1], LATERALS, bins)
    lateral = np.argmax(probabilities.sum(axis=-1), axis=-1)
    conditional = np.take_along_axis(probabilities, lateral[..., None, None], axis=-2)[..., 0, :]
    conditional = conditional / conditional.sum(axis=-1, keepdims=True)
    if decoding == "expected":
        chosen = np.rint(conditional @ np.arange(bins, dtype=np.float64)).astype(np.int64)
    else:
        chosen = np.argmax(np.cumsum(conditional, axis=-1) >= 0.5, axis=-1)
    return lateral * bins + chosen
