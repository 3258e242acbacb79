"""The RAIL discriminator D(s, a) in [0, 1], trained with the LS-GAN loss, and its reward log D - log(1 - D).

Input: the observation normalised by fixed statistics (e.g. the expert's), concatenated with the one-hot action.
Network: two tanh hidden layers then a sigmoid, the discriminator of GAIL (Ho & Ermon, 2016), which RAIL builds
on; the paper gives no architecture of its own. The model is float32; initialisation and minibatch sampling draw
from the discriminator's own seeded `torch.Generator` and torch runs on one thread during each call (faster for
this small network, and independent of the thread count), so the same seed and data give bit-identical results
and `state` / `load_state` resume exactly.
"""

from __future__ import annotations

import copy
import logging
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import nn

from sumo_rail.bounds import ConfigError, bounded, check_fields, given
from sumo_rail.drivers.policies import MIN_STD
from sumo_rail.learning.torch_threads import single_thread

logger = logging.getLogger(__name__)


REWARD_FORMS = ("logit", "contrast")
"""The forms of the discriminator's reward (`DiscriminatorSettings.reward_form`)."""


@dataclass(frozen=True)
class DiscriminatorSettings:
    hidden: int = bounded(1, 4096, default=64)
    """Units of each of the two hidden layers."""
    learning_rate: float = bounded(0, 1, default=3e-4, low_open=True)
    """Adam step size."""
    steps_per_iteration: int = bounded(1, 10_000, default=10)
    """Gradient steps per `train` call."""
    batch_size: int = bounded(1, 1_000_000, default=512)
    """Expert pairs and policy pairs per step (each sampled with replacement)."""
    reward_clip: float = bounded(0, 0.5, default=1e-3, low_open=True, high_open=True)
    """D is clipped to [clip, 1 - clip] before the log, bounding the reward by log((1 - clip) / clip)."""
    seed: int = given("--seed", 0)
    reward_form: str = "logit"
    """'logit': log D(s, a) - log(1 - D(s, a)), the paper's reward; 'contrast': that minus its mean over every action
    at the same state, so the part that depends on the state alone (how expert-like the visited traffic is) cancels
    and only the choice among the actions at that state is rewarded."""
    balance: float = bounded(0, 10, default=0.0)
    """Minibatches draw each side's pairs with weights (1 / frequency of their action on that side)^balance: 0 draws
    pairs uniformly, 1 every action equally often (the rare lane changes as often as keeping the lane)."""
    gradient_penalty: float = bounded(0, 1e6, default=0.0)
    """Weight of the mean squared norm of the gradient of D's logit with respect to its input at expert pairs (R1,
    Mescheder et al. 2018), added to the loss: it keeps D smooth rather than chasing the last policy's pairs."""
    replay: int = bounded(1, 100_000, default=1)
    """Policy pairs of this many most recent `train` calls (RAIL iterations) are the policy side of each minibatch;
    1: the current call's only, as the paper."""

    def __post_init__(self) -> None:
        check_fields(self, "discriminator.")
        if self.reward_form not in REWARD_FORMS:
            raise ConfigError(f"discriminator.reward_form must be one of {', '.join(REWARD_FORMS)}, got "
                              f"{self.reward_form!r}")


@dataclass(frozen=True)
class DiscriminatorReport:
    loss: float
    """LS-GAN loss on all pairs given, after the steps."""
    accuracy: float
    """Share of all pairs given classified correctly: expert with D > 0.5, policy with D < 0.5."""


def lsgan_loss(d_expert: torch.Tensor, d_policy: torch.Tensor) -> torch.Tensor:
    """The paper's LS-GAN loss with labels b = 1 (expert) and a = 0 (policy):
    1/2 mean((D(expert) - 1)^2) + 1/2 mean(D(policy)^2)."""
    return 0.5 * torch.mean((d_expert - 1.0) ** 2) + 0.5 * torch.mean(d_policy**2)


class Discriminator:
    """D(s, a): probability that a state-action pair comes from the expert."""

    def __init__(self, observation_size: int, observation_mean: np.ndarray, observation_std: np.ndarray,
                 settings: DiscriminatorSettings, actions: int = 5) -> None:
        mean = np.asarray(observation_mean, dtype=np.float64)
        std = np.asarray(observation_std, dtype=np.float64)
        if observation_size < 1 or actions < 2 or settings.hidden < 1:
            raise ValueError(f"discriminator sizes must be positive with at least 2 actions, got {observation_size} "
                             f"observations, {actions} actions and {settings.hidden} hidden units")
        if mean.shape != (observation_size,) or std.shape != (observation_size,):
            raise ValueError(f"normalisation statistics must have shape ({observation_size},), got {mean.shape} "
                             f"and {std.shape}")
        self.observation_size, self.actions, self.settings = observation_size, actions, settings
        self._mean = torch.as_tensor(mean, dtype=torch.float32)
        self._scale = torch.as_tensor(1.0 / np.where(std < MIN_STD, 1.0, std), dtype=torch.float32)
        size, hidden = observation_size + actions, settings.hidden
        linears = [nn.utils.skip_init(nn.Linear, size, hidden), nn.utils.skip_init(nn.Linear, hidden, hidden),
                   nn.utils.skip_init(nn.Linear, hidden, 1)]
        self._generator = torch.Generator().manual_seed(settings.seed)
        for layer in linears:  # PyTorch's default bounds, drawn from our generator
            bound = 1.0 / np.sqrt(layer.in_features)
            nn.init.uniform_(layer.weight, -bound, bound, generator=self._generator)
            nn.init.uniform_(layer.bias, -bound, bound, generator=self._generator)
        self._network = nn.Sequential(linears[0], nn.Tanh(), linears[1], nn.Tanh(), linears[2])
        self._optimiser = torch.optim.Adam(self._network.parameters(), lr=settings.learning_rate)
        self._replay: list[torch.Tensor] = []
        """Policy inputs of the last `settings.replay` train calls, oldest first."""

    def probability(self, observations: np.ndarray, actions: np.ndarray) -> np.ndarray:
        """D of pairs (observations (B, n), actions (B,)), shape (B,) float64."""
        logits = self._logits(observations, actions).astype(np.float64)
        return 0.5 * (1.0 + np.tanh(0.5 * logits))  # the sigmoid, without overflow

    def reward(self, observations: np.ndarray, actions: np.ndarray) -> np.ndarray:
        """RAIL's reward of pairs, shape (B,) float64 (nats), in the settings' form: log D - log(1 - D) with D clipped
        to [clip, 1 - clip]; with the 'contrast' form minus the mean of that over all actions at the same state."""
        clip = self.settings.reward_clip
        if self.settings.reward_form == "logit":
            d = np.clip(self.probability(observations, actions), clip, 1.0 - clip)
            return np.log(d) - np.log1p(-d)
        observations = np.asarray(observations, dtype=np.float32)
        rows = len(observations)
        every = np.tile(np.arange(self.actions), rows)
        d = np.clip(self.probability(np.repeat(observations, self.actions, axis=0), every), clip, 1.0 - clip)
        log_odds = (np.log(d) - np.log1p(-d)).reshape(rows, self.actions)
        taken = log_odds[np.arange(rows), np.asarray(actions, dtype=np.int64)]
        return taken - log_odds.mean(axis=1)

    def lowest_reward(self) -> float:
        """The lowest reward the clipped D can give in the settings' form (nats): -log((1 - clip) / clip) for
        'logit'; for 'contrast', the taken action at the lowest log odds and every other at the highest."""
        bound = float(np.log1p(-self.settings.reward_clip) - np.log(self.settings.reward_clip))
        if self.settings.reward_form == "logit":
            return -bound
        return -bound - (self.actions - 2) * bound / self.actions

    def train(self, expert_observations: np.ndarray, expert_actions: np.ndarray, policy_observations: np.ndarray,
              policy_actions: np.ndarray) -> DiscriminatorReport:
        """`steps_per_iteration` Adam steps on the LS-GAN loss, each on `batch_size` expert and policy pairs."""
        expert = self._inputs(expert_observations, expert_actions)
        policy = self._inputs(policy_observations, policy_actions)
        if len(expert) == 0 or len(policy) == 0:
            raise ValueError("discriminator training needs at least one expert pair and one policy pair")
        self._replay = [*self._replay, policy][-self.settings.replay:]
        with single_thread():
            return self._train(expert, torch.cat(self._replay), policy)

    def _train(self, expert: torch.Tensor, policy: torch.Tensor, current: torch.Tensor) -> DiscriminatorReport:
        """The steps of `train` on input tensors (B, n + actions), the policy side drawn from `policy`; the report is
        measured on the expert's pairs and the `current` policy pairs."""
        batch = self.settings.batch_size
        expert_weights, policy_weights = self._sampling_weights(expert), self._sampling_weights(policy)
        for _ in range(self.settings.steps_per_iteration):
            expert_rows = self._draw(expert_weights, len(expert), batch)
            policy_rows = self._draw(policy_weights, len(policy), batch)
            expert_batch = expert[expert_rows].requires_grad_(self.settings.gradient_penalty > 0)
            expert_logits = self._network(expert_batch)
            loss = lsgan_loss(torch.sigmoid(expert_logits), torch.sigmoid(self._network(policy[policy_rows])))
            if self.settings.gradient_penalty > 0:
                gradient, = torch.autograd.grad(expert_logits.sum(), expert_batch, create_graph=True)
                loss = loss + self.settings.gradient_penalty * gradient.pow(2).sum(dim=1).mean()
            self._optimiser.zero_grad()
            loss.backward()
            self._optimiser.step()
        with torch.no_grad():
            d_expert, d_policy = torch.sigmoid(self._network(expert)), torch.sigmoid(self._network(current))
        correct = int((d_expert > 0.5).sum()) + int((d_policy < 0.5).sum())
        report = DiscriminatorReport(loss=float(lsgan_loss(d_expert, d_policy)),
                                     accuracy=correct / (len(expert) + len(current)))
        logger.debug("discriminator: loss %.4f, accuracy %.3f", report.loss, report.accuracy)
        return report

    def _sampling_weights(self, inputs: torch.Tensor) -> torch.Tensor | None:
        """Row weights (1 / frequency of the row's action)^balance, or None to draw rows uniformly."""
        if self.settings.balance == 0:
            return None
        actions = inputs[:, self.observation_size:].argmax(dim=1)
        counts = torch.bincount(actions, minlength=self.actions).to(torch.float64)
        return counts[actions].pow(-self.settings.balance)

    def _draw(self, weights: torch.Tensor | None, rows: int, batch: int) -> torch.Tensor:
        """`batch` row indices drawn with replacement, uniformly or by `weights`, from the own generator."""
        if weights is None:
            return torch.randint(rows, (batch,), generator=self._generator)
        return torch.multinomial(weights, batch, replacement=True, generator=self._generator)

    def state(self) -> dict[str, Any]:
        """Model, optimiser, generator and replayed pairs as tensors and plain types (torch.load(weights_only=True)
        reads it). A copy: later training does not change it."""
        return copy.deepcopy({"model": self._network.state_dict(), "optimizer": self._optimiser.state_dict(),
                              "generator": self._generator.get_state(), "replay": self._replay})

    def load_state(self, state: dict[str, Any]) -> None:
        """Resume from `state()` of a discriminator built with the same sizes and settings."""
        self._network.load_state_dict(state["model"])
        self._optimiser.load_state_dict(copy.deepcopy(state["optimizer"]))
        self._generator.set_state(state["generator"])
        self._replay = list(state.get("replay", []))  # absent in checkpoints written before replay existed

    def _inputs(self, observations: np.ndarray, actions: np.ndarray) -> torch.Tensor:
        """Normalised observations and one-hot actions, shape (B, n + actions) float32."""
        observations = np.asarray(observations, dtype=np.float32)
        actions = np.asarray(actions, dtype=np.int64)
        if observations.ndim != 2 or observations.shape[1] != self.observation_size:
            raise ValueError(f"the discriminator expects observations of shape (B, {self.observation_size}), "
                             f"got {observations.shape}")
        if actions.shape != (len(observations),):
            raise ValueError(f"the discriminator expects {len(observations)} actions, got shape {actions.shape}")
        if len(actions) and (actions.min() < 0 or actions.max() >= self.actions):
            raise ValueError(f"actions must be in 0..{self.actions - 1}")
        normalised = (torch.tensor(observations, dtype=torch.float32) - self._mean) * self._scale  # a copy
        one_hot = nn.functional.one_hot(torch.tensor(actions, dtype=torch.int64), self.actions).to(torch.float32)
        return torch.cat([normalised, one_hot], dim=1)

    def _logits(self, observations: np.ndarray, actions: np.ndarray) -> np.ndarray:
        """Pre-sigmoid outputs, shape (B,) float32."""
        inputs = self._inputs(observations, actions)
        with torch.no_grad(), single_thread():
            return self._network(inputs).reshape(-1).numpy()
