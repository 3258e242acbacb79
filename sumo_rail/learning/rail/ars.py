"""The ARS V2-t update (Mania et al. 2018, Algorithm 2) and RAIL's noise adaptation, as pure functions.

Mapping to the RAIL paper (Algorithm 1):
- line 17, the update: theta += alpha / (b sigma_R) * sum_k (r+_k - r-_k) delta_k, with r+-_k the discriminator
  returns of theta +- nu delta_k. The paper sums over all N directions (b = N, `top=N` here); `top < N` keeps only
  the b directions with the largest max(r+, r-), as in ARS V2-t, and sigma_R is the population std of their 2b
  returns. nu scales the perturbations only; it does not appear in the update.
- lines 20-24, the noise coefficient: every eta iterations the caller compares performance, the best mean
  discriminator return seen up to the previous check (`best_before`) against the best seen up to now
  (`best_now`). Saturation (no improvement) increases nu by tau; improvement returns nu to nu_init. The paper's
  pseudo-code ("if t == eta ... else nu = nu_init") would reset nu at every other iteration; we follow its text
  ("we periodically check ... and increase nu whenever we detect performance saturation"): nu is unchanged
  between checks. The paper's values are nu_init = 0.03 and tau = 0.001; eta is not given (10 here).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import rankdata

from sumo_rail.bounds import bounded, check_fields


@dataclass(frozen=True, eq=False)
class ArsStep:
    """The result of one ARS update."""

    parameters: np.ndarray
    """New parameters, flat float32, shape (P,)."""
    reward_std: float
    """sigma_R: population std of the 2b selected returns (r+ and r- of the top b directions)."""
    selected: np.ndarray
    """Indices of the top b directions, shape (b,), by max(r+, r-) descending, ties by lower index."""


FITNESS_SHAPINGS = ("std", "rank")
"""How `ars_update` scales the returns: 'std' divides by sigma_R (ARS); 'rank' replaces them by centred ranks."""


def centred_ranks(returns: np.ndarray) -> np.ndarray:
    """Salimans et al. (2017)'s fitness shaping: each return's rank among all of them (ties share their mean rank)
    mapped linearly onto [-0.5, 0.5], same shape."""
    values = np.asarray(returns, dtype=np.float64)
    if values.size < 2:
        return np.zeros_like(values)
    return (rankdata(values, method="average").reshape(values.shape) - 1.0) / (values.size - 1) - 0.5


def ars_update(parameters: np.ndarray, deltas: np.ndarray, returns_plus: np.ndarray, returns_minus: np.ndarray,
               top: int, step_size: float, shaping: str = "std") -> ArsStep:
    """One ARS V2-t step from N directions `deltas` (N, P) and the returns (N,) of theta +- nu delta_k.

    'std' shaping: theta + step_size / (top sigma_R) * sum_{k in top} (r+_k - r-_k) delta_k, computed in float64
    and cast to float32; if sigma_R is 0 (all selected returns equal) the parameters are returned unchanged.
    'rank' shaping: the 2N returns are replaced by their centred ranks (`centred_ranks`) and the step is
    step_size / top * sum_{k in top} (rank+_k - rank-_k) delta_k, with no division by sigma_R (reported all the
    same); the top directions are chosen on the returns either way.
    """
    theta = np.asarray(parameters)
    deltas = np.asarray(deltas)
    plus, minus = np.asarray(returns_plus, dtype=np.float64), np.asarray(returns_minus, dtype=np.float64)
    if theta.ndim != 1:
        raise ValueError(f"parameters must be a flat vector, got shape {theta.shape}")
    if deltas.ndim != 2 or deltas.shape[1] != theta.shape[0]:
        raise ValueError(f"deltas must have shape (N, {theta.shape[0]}), got {deltas.shape}")
    count = deltas.shape[0]
    if plus.shape != (count,) or minus.shape != (count,):
        raise ValueError(f"returns must have shape ({count},), got {plus.shape} and {minus.shape}")
    if not (np.all(np.isfinite(plus)) and np.all(np.isfinite(minus))):
        raise ValueError("returns must be finite")
    if not 1 <= top <= count:
        raise ValueError(f"top must be between 1 and the number of directions {count}, got {top}")
    if shaping not in FITNESS_SHAPINGS:
        raise ValueError(f"fitness shaping must be one of {', '.join(FITNESS_SHAPINGS)}, got {shaping!r}")
    selected = np.argsort(-np.maximum(plus, minus), kind="stable")[:top]
    reward_std = float(np.std(np.concatenate([plus[selected], minus[selected]])))
    if reward_std == 0.0:
        return ArsStep(theta.astype(np.float32), reward_std, selected)
    if shaping == "rank":
        ranks = centred_ranks(np.concatenate([plus, minus]))
        plus, minus, scale = ranks[:count], ranks[count:], step_size / top
    else:
        scale = step_size / (top * reward_std)
    step = (plus[selected] - minus[selected]) @ deltas[selected].astype(np.float64)
    new = theta.astype(np.float64) + scale * step
    return ArsStep(new.astype(np.float32), reward_std, selected)


@dataclass(frozen=True)
class NoiseAdaptation:
    """Schedule of the noise coefficient nu (RAIL, Algorithm 1, lines 20-24)."""

    initial: float = bounded(0, 10, default=0.03, low_open=True)
    """nu_init, the perturbation scale after an improvement (parameter units)."""
    increment: float = bounded(0, 10, default=0.001)
    """tau, added to nu at each check without improvement."""
    every: int = bounded(1, 1_000_000, default=10)
    """eta, iterations between checks."""

    def __post_init__(self) -> None:
        check_fields(self, "rail.noise.")


def adapt_noise(nu: float, iteration: int, best_before: float, best_now: float, schedule: NoiseAdaptation) -> float:
    """nu for the next iteration after (0-based) `iteration`; checks happen when (iteration + 1) % every == 0.

    At a check: nu + increment if best_now <= best_before (no improvement), else schedule.initial.
    """
    if (iteration + 1) % schedule.every != 0:
        return nu
    return nu + schedule.increment if best_now <= best_before else schedule.initial
