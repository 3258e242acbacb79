"""Behaviour cloning: fit a Policy to demonstrations by cross-entropy over the actions, with torch.

`PolicyNetwork` is the torch twin of `policies.Policy`: same layers, same frozen normalisation and the flat
parameter layout documented in `sumo_rail.drivers.policies` (per layer: W (out, in) row-major, then b), so converting
either way preserves the logits. Training is bit-identical for the same inputs and seed: initialisation and
shuffling draw from a seeded `torch.Generator`, the holdout split from a seeded numpy Generator, and torch runs
on one thread during the call.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from sumo_rail.bounds import bounded, check_fields, given
from sumo_rail.drivers.policies import MIN_STD, Policy, PolicyShape
from sumo_rail.learning.torch_threads import single_thread
from sumo_rail.runners.tables import Demonstrations

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class BcSettings:
    epochs: int = bounded(0, 10_000, default=20)
    """Passes over the demonstrations (0: no behaviour cloning before train and gail; dagger, whose every round is
    behaviour cloning, needs at least 1)."""
    batch_size: int = bounded(1, 1_000_000, default=256)
    """Decisions per gradient step."""
    learning_rate: float = bounded(0, 1, default=1e-3, low_open=True)
    """Adam step size."""
    holdout_fraction: float = bounded(0, 1, default=0.2, high_open=True)
    """Share of demonstration episodes held out for accuracy (at least one when there are two or more)."""
    class_balance: float = bounded(0, 10, default=0.75)
    """Exponent p of the cross-entropy's class weights (1 / frequency)^p, normalised to a mean weight of 1 per
    row: 0 is the plain cross-entropy, 1 weighs every action equally. An expert keeps its lane in ~96% of its
    decisions, so plain BC never changes lanes. p = 0.75 came closest to the expert's lane changes among 0, 0.5,
    0.65, 0.75 and 1, and agrees with the expert more than p = 0 on validation episodes (+0.48 [+0.25, +0.72],
    docs/results.md, "BC's class balance")."""
    seed: int = given("--seed", 0)

    def __post_init__(self) -> None:
        check_fields(self, "bc.")


IMITATION_BC = BcSettings()
"""The behaviour cloning that initialises the imitation commands' policies (train, dagger, gail): their defaults."""


@dataclass(frozen=True)
class BcReport:
    train_accuracy: float
    """Share of training rows where the policy's action (`Policy.act`, by its shape's decoding) is the demonstrated
    one."""
    holdout_accuracy: float | None
    """The same on the held-out rows; None when the demonstrations hold a single episode."""
    losses: list[float]
    """Mean cross-entropy (nats per row) of each epoch."""
    train_rows: int
    holdout_rows: int
    majority_accuracy: float | None = None
    """The held-out accuracy of always choosing the training rows' commonest action (the baseline a held-out
    accuracy beats or not); None without a holdout."""
    argmax_holdout_accuracy: float | None = None
    """The held-out accuracy of the logits' argmax when the policy decodes otherwise (`PolicyShape.decoding`); None
    when it decodes by argmax (holdout_accuracy is that) or without a holdout."""


class PolicyNetwork(nn.Module):
    """Torch twin of a Policy: float32 logits (B, actions) of raw observations (B, n), any float dtype.

    The weights start uninitialised: build it with `policy_to_torch` or initialise them."""

    mean: torch.Tensor
    """The observation means (float64 buffer)."""
    scale: torch.Tensor
    """1 / the floored observation stds (float64 buffer)."""

    def __init__(self, shape: PolicyShape, observation_mean: np.ndarray, observation_std: np.ndarray) -> None:
        super().__init__()
        self.shape = shape
        self.observation_mean = np.asarray(observation_mean, dtype=np.float64)
        self.observation_std = np.asarray(observation_std, dtype=np.float64)
        n, h, a = shape.observation_size, shape.hidden, shape.actions
        if shape.kind == "linear":
            self.layers = nn.Sequential(nn.utils.skip_init(nn.Linear, n, a))
        else:
            self.layers = nn.Sequential(nn.utils.skip_init(nn.Linear, n, h), nn.Tanh(),
                                        nn.utils.skip_init(nn.Linear, h, a))
        scale = 1.0 / np.maximum(self.observation_std, MIN_STD)  # exactly as Policy normalises
        self.register_buffer("mean", torch.as_tensor(self.observation_mean, dtype=torch.float64))
        self.register_buffer("scale", torch.as_tensor(scale, dtype=torch.float64))

    def linears(self) -> list[nn.Linear]:
        """The linear layers in parameter-layout order."""
        return [layer for layer in self.layers if isinstance(layer, nn.Linear)]

    def forward(self, observations: torch.Tensor) -> torch.Tensor:
        """Normalised in float64 like Policy (floored stds scale by up to 1e6), then float32 layers."""
        return self.layers(((observations.double() - self.mean) * self.scale).float())


def policy_to_torch(policy: Policy) -> PolicyNetwork:
    """A PolicyNetwork holding the policy's parameters and normalisation statistics."""
    network = PolicyNetwork(policy.shape, policy.observation_mean, policy.observation_std)
    values, offset = torch.from_numpy(policy.parameters.copy()), 0
    with torch.no_grad():
        for layer in network.linears():
            for parameter in (layer.weight, layer.bias):
                parameter.copy_(values[offset:offset + parameter.numel()].view_as(parameter))
                offset += parameter.numel()
    return network


def torch_to_parameters(network: PolicyNetwork) -> np.ndarray:
    """The flat float32 parameter vector of the documented layout, shape (parameter_count,)."""
    parts = [tensor.detach().reshape(-1) for layer in network.linears() for tensor in (layer.weight, layer.bias)]
    return torch.cat(parts).numpy().astype(np.float32)


def torch_to_policy(network: PolicyNetwork) -> Policy:
    """The numpy Policy equivalent to `network`."""
    return Policy(network.shape, torch_to_parameters(network), network.observation_mean, network.observation_std)


def split_episodes(episodes: np.ndarray, holdout_fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Boolean row masks (train, holdout) holding out whole episodes: round(fraction x episodes), clamped to
    1 .. episodes - 1, chosen by a numpy Generator seeded with `seed`; no holdout for a single episode."""
    names = np.unique(episodes)
    count = min(max(1, round(holdout_fraction * len(names))), len(names) - 1)
    chosen = np.random.default_rng(seed).permutation(names)[:count]
    holdout = np.isin(episodes, chosen)
    return ~holdout, holdout


def behaviour_cloning(demos: Demonstrations, shape: PolicyShape, settings: BcSettings) -> tuple[Policy, BcReport]:
    """Train a policy of `shape` on `demos`; its normalisation is the mean / std of the training observations."""
    observations = np.asarray(demos.observations, dtype=np.float32)
    actions = np.asarray(demos.actions, dtype=np.int64)
    _check(observations, actions, shape, settings)
    train, holdout = split_episodes(np.asarray(demos.episodes), settings.holdout_fraction, settings.seed)
    mean = observations[train].mean(axis=0, dtype=np.float64)
    std = observations[train].std(axis=0, dtype=np.float64)
    std[std < MIN_STD] = 1.0  # constant features pass through unscaled
    with single_thread():
        generator = torch.Generator().manual_seed(settings.seed)
        network = PolicyNetwork(shape, mean, std)
        for layer in network.linears():  # PyTorch's default bounds, drawn from our generator
            bound = 1.0 / np.sqrt(layer.in_features)
            nn.init.uniform_(layer.weight, -bound, bound, generator=generator)
            nn.init.uniform_(layer.bias, -bound, bound, generator=generator)
        losses = _fit(network, torch.from_numpy(observations[train]), torch.from_numpy(actions[train]), settings,
                      generator)
    policy = torch_to_policy(network)
    report = BcReport(train_accuracy=_accuracy(policy, observations[train], actions[train]),
                      holdout_accuracy=_accuracy(policy, observations[holdout], actions[holdout]) if holdout.any()
                      else None, losses=losses, train_rows=int(train.sum()), holdout_rows=int(holdout.sum()),
                      majority_accuracy=majority_accuracy(actions[train], actions[holdout]),
                      argmax_holdout_accuracy=_accuracy(policy.decoded_by("argmax"), observations[holdout],
                                                        actions[holdout])
                      if holdout.any() and shape.decoding != "argmax" else None)
    logger.info("behaviour cloning: loss %.4f, train accuracy %.3f, holdout accuracy %s", losses[-1],
                report.train_accuracy, "n/a" if report.holdout_accuracy is None else f"{report.holdout_accuracy:.3f}")
    return policy, report


def _fit(network: PolicyNetwork, observations: torch.Tensor, actions: torch.Tensor, settings: BcSettings,
         generator: torch.Generator) -> list[float]:
    """Adam on the cross-entropy, shuffled minibatches; returns the mean loss of each epoch."""
    optimiser = torch.optim.Adam(network.parameters(), lr=settings.learning_rate)
    weights = class_weights(actions, network.shape.actions, settings.class_balance)
    losses: list[float] = []
    for epoch in range(settings.epochs):
        order, total = torch.randperm(len(actions), generator=generator), 0.0
        for start in range(0, len(order), settings.batch_size):
            batch = order[start:start + settings.batch_size]
            loss = nn.functional.cross_entropy(network(observations[batch]), actions[batch], weight=weights)
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            total += loss.item() * len(batch)
        losses.append(total / len(order))
        logger.debug("behaviour cloning epoch %d: loss %.4f", epoch + 1, losses[-1])
    return losses


def class_weights(actions: torch.Tensor, count: int, balance: float) -> torch.Tensor:
    """Weights (count,) float32 proportional to (1 / frequency)^balance with a row-weighted mean of 1 (absent
    actions get the largest weight, as if seen once)."""
    frequency = torch.bincount(actions, minlength=count).double()
    weights = frequency.clamp(min=1.0).pow(-balance)
    return (weights * len(actions) / (weights * frequency).sum()).float()


def majority_accuracy(train: np.ndarray, holdout: np.ndarray) -> float | None:
    """Share of `holdout` actions equal to the commonest of `train` (ties: lowest index); None for no holdout."""
    return float(np.mean(holdout == np.bincount(train).argmax())) if len(holdout) else None


def _accuracy(policy: Policy, observations: np.ndarray, actions: np.ndarray) -> float:
    """Share of rows where `policy.act` picks the demonstrated action (by the policy's decoding, as act)."""
    return float(np.mean(policy.acts(observations) == actions))


def _check(observations: np.ndarray, actions: np.ndarray, shape: PolicyShape, settings: BcSettings) -> None:
    if settings.epochs < 1 or settings.batch_size < 1 or settings.learning_rate <= 0:
        raise ValueError(f"behaviour cloning needs epochs >= 1, batch_size >= 1 and learning_rate > 0, got {settings}")
    if settings.class_balance < 0:
        raise ValueError(f"class_balance must not be negative, got {settings.class_balance}")
    if not 0.0 <= settings.holdout_fraction < 1.0:
        raise ValueError(f"holdout_fraction must be in [0, 1), got {settings.holdout_fraction}")
    if len(actions) == 0:
        raise ValueError("behaviour cloning needs at least one demonstration")
    if observations.ndim != 2 or observations.shape[1] != shape.observation_size:
        raise ValueError(f"demonstrations have observations of shape {observations.shape[1:]}, "
                         f"the policy expects ({shape.observation_size},)")
    if actions.min() < 0 or actions.max() >= shape.actions:
        raise ValueError(f"demonstrated actions must be in 0..{shape.actions - 1}")
