"""GAIL's actor is RAIL's: the PPO actor has exactly the layout of a `PolicyShape` (mlp: Linear(n, h) + tanh, then
Linear(h, 5); linear: Linear(n, 5)) on observations normalised by FIXED statistics (the BC policy's, or the expert
demonstrations' without BC), so a `Policy` loads into it (`load_into_ppo`) and it exports as one that
`sumo-rail evaluate` reads (`ppo_to_policy`); the critic is a separate CRITIC_LAYERS tanh MLP.

The critic warm-up freezes the actor (`set_actor_trainable`) while the value network alone learns: PPO's critic
starts untrained, and the advantages it gives in the first updates are noise that would walk the BC-initialised
actor away from BC before the reward is known. A frozen parameter gets no gradient, so Adam keeps no state for it
and the actor's first real step is an ordinary first step. Stable-Baselines3 appears here only in type hints.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from torch import nn

from sumo_rail.drivers.policies import Policy, PolicyShape
from sumo_rail.learning.bc import policy_to_torch
from sumo_rail.learning.rail.normalize import MIN_STD

if TYPE_CHECKING:
    from stable_baselines3.common.policies import ActorCriticPolicy

CRITIC_LAYERS = (64, 64)
"""Hidden tanh units of PPO's value network (separate from the actor)."""


@dataclass(frozen=True)
class FixedNormalisation:
    """(observation - mean) / std in float64 exactly as `Policy` computes it, returned as float32 for PPO."""

    mean: np.ndarray
    std: np.ndarray

    def __call__(self, observations: np.ndarray) -> np.ndarray:
        scale = 1.0 / np.maximum(self.std, MIN_STD)
        return ((np.asarray(observations, dtype=np.float64) - self.mean) * scale).astype(np.float32)


def policy_kwargs(shape: PolicyShape) -> dict[str, Any]:
    """SB3 `policy_kwargs` whose actor has exactly the layout of `shape`."""
    actor = [shape.hidden] if shape.kind == "mlp" else []
    return {"net_arch": {"pi": actor, "vf": list(CRITIC_LAYERS)}, "activation_fn": nn.Tanh}


def _actor_linears(ppo_policy: ActorCriticPolicy) -> list[nn.Linear]:
    """The actor's linear layers in `sumo_rail.drivers.policies` parameter-layout order."""
    layers = [*ppo_policy.mlp_extractor.policy_net, ppo_policy.action_net]
    return [layer for layer in layers if isinstance(layer, nn.Linear)]


def load_into_ppo(policy: Policy, ppo_policy: ActorCriticPolicy) -> None:
    """Copy `policy`'s weights into the PPO actor, whose observations must be normalised by the policy's statistics."""
    sources, targets = policy_to_torch(policy).linears(), _actor_linears(ppo_policy)
    if [layer.weight.shape for layer in sources] != [layer.weight.shape for layer in targets]:
        raise ValueError(f"the PPO actor does not have the layout of a {policy.shape}")
    with torch.no_grad():
        for source, target in zip(sources, targets, strict=True):
            target.weight.copy_(source.weight)
            target.bias.copy_(source.bias)


def set_actor_trainable(ppo_policy: ActorCriticPolicy, trainable: bool) -> None:
    """Let PPO's updates move the actor or freeze it: a frozen parameter gets no gradient, so Adam leaves it and its
    moments untouched while the critic (and its optimizer state) learns."""
    for layer in _actor_linears(ppo_policy):
        layer.requires_grad_(trainable)


def ppo_to_policy(ppo_policy: ActorCriticPolicy, shape: PolicyShape, normalisation: FixedNormalisation) -> Policy:
    """The PPO actor as a `Policy` of `shape` on raw observations; act = PPO's deterministic predict (up to float32
    near-ties) when `shape` decodes by argmax."""
    parts = [tensor.detach().reshape(-1) for layer in _actor_linears(ppo_policy)
             for tensor in (layer.weight, layer.bias)]
    return Policy(shape, torch.cat(parts).numpy().astype(np.float32), normalisation.mean, normalisation.std)
