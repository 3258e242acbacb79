"""Continuing a Stable-Baselines3 run (`gail`, `ppo`) from its last completed update.

After every update the run folder's checkpoint.pt holds what the learner carries from one update to the next: the
actor-critic's weights, Adam's state, the timestep count, the global torch and numpy generators (PPO samples actions
from torch's and shuffles its minibatches with numpy's), the reward normaliser's running statistics, the fixed
observation statistics, the log and, for GAIL, the discriminator (weights, optimiser, generator, replay). A resumed
run restores all of it exactly. What it cannot restore is the SUMO simulations: the episodes under way at the update's
end are dropped, and every environment starts a new episode, seeded by `resumed_env_seed` (deterministic, so a
resumed run repeats bit for bit, but the updates after the resume differ from an uninterrupted run's).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch

from sumo_rail.datasets import describe
from sumo_rail.learning.run_folder import RunError, check_resumable, load_checkpoint, write_run_record
from sumo_rail.learning.sb3.actor import FixedNormalisation

if TYPE_CHECKING:
    from stable_baselines3 import PPO

    from sumo_rail.learning.rail.discriminator import Discriminator

CHECKPOINT_FORMAT = "sumo-rail sb3 checkpoint 1"
RESUME_SEED_STRIDE = 1_000_003
"""Resuming after update u seeds the environments' new episodes as a run of seed `seed + u x this` would."""


def resumed_env_seed(seed: int, updates_done: int) -> int:
    """The base seed of the environments' first episodes when a run of `seed` resumes after `updates_done` updates
    (`seed` itself for a new run)."""
    return seed + RESUME_SEED_STRIDE * updates_done


def learner_checkpoint(model: PPO, normalisation: FixedNormalisation, rows: list[dict[str, Any]],
                       **extra: Any) -> dict[str, Any]:
    """What `restore_learner` needs after the update of the last of `rows`, as tensors and plain values (loadable
    with weights_only); `extra` adds entries (e.g. GAIL's discriminator)."""
    state = np.random.get_state(legacy=True)
    assert isinstance(state, tuple)  # the global RandomState's bit generator is an MT19937
    keys, position, has_gauss, cached = state[1:]
    normaliser = model.get_vec_normalize_env()
    return {"format": CHECKPOINT_FORMAT, "updates": len(rows), "log": rows,
            "policy": model.policy.state_dict(), "optimizer": model.policy.optimizer.state_dict(),
            "num_timesteps": model.num_timesteps, "n_updates": model._n_updates,  # noqa: SLF001 - SB3 keeps it private
            "torch_rng": torch.get_rng_state(),
            "numpy_rng": {"keys": torch.from_numpy(keys.astype(np.int64)), "position": int(position),
                          "has_gauss": int(has_gauss), "cached_gaussian": float(cached)},
            "reward_rms": None if normaliser is None else {
                "mean": float(normaliser.ret_rms.mean), "var": float(normaliser.ret_rms.var),
                "count": float(normaliser.ret_rms.count)},
            "observation_mean": torch.from_numpy(np.asarray(normalisation.mean, np.float64).copy()),
            "observation_std": torch.from_numpy(np.asarray(normalisation.std, np.float64).copy()), **extra}


def restore_learner(model: PPO, checkpoint: dict[str, Any], path: Path,
                    discriminator: Discriminator | None = None) -> None:
    """Put a freshly built `model` (and the global generators, and GAIL's `discriminator`) in the state `checkpoint`
    (read from `path`) holds."""
    try:
        if discriminator is not None:
            discriminator.load_state(checkpoint["discriminator"])
        model.policy.load_state_dict(checkpoint["policy"])
        model.policy.optimizer.load_state_dict(checkpoint["optimizer"])
        model.num_timesteps, model._n_updates = (  # noqa: SLF001 - SB3 keeps the update count private
            int(checkpoint["num_timesteps"]), int(checkpoint["n_updates"]))
        torch.set_rng_state(checkpoint["torch_rng"])
        generator = checkpoint["numpy_rng"]
        np.random.set_state(("MT19937", generator["keys"].numpy().astype(np.uint32), generator["position"],
                             generator["has_gauss"], generator["cached_gaussian"]))
        normaliser, statistics = model.get_vec_normalize_env(), checkpoint["reward_rms"]
        if (normaliser is None) != (statistics is None):
            raise ValueError("reward normalisation differs from the run's")
        if normaliser is not None:
            normaliser.ret_rms.mean, normaliser.ret_rms.var = statistics["mean"], statistics["var"]
            normaliser.ret_rms.count = statistics["count"]
    except KeyError as error:
        raise RunError(f"checkpoint {path} lacks its entry {error}") from error
    except (TypeError, ValueError, AttributeError, RuntimeError) as error:
        raise RunError(f"checkpoint {path} is inconsistent ({describe(error)})") from error


def resume_run(folder: Path, run_record: dict[str, Any], defaults: dict[str, Any] | None = None) -> dict[str, Any]:
    """The checkpoint of the run in `folder` after checking it is this run (`run_record`: the same settings but the
    timesteps, those added since it was written read as their `defaults`, the same configuration) and whole; rewrites
    run.json with the new timesteps. A missing, damaged, foreign or mismatched file is a RunError naming it."""
    path = folder / "checkpoint.pt"
    check_resumable(folder, path.name, run_record, defaults, free=("timesteps",))
    checkpoint = load_checkpoint(path, CHECKPOINT_FORMAT)
    try:
        updates, rows = int(checkpoint["updates"]), list(checkpoint["log"])
        normalisation = FixedNormalisation(checkpoint["observation_mean"].numpy(),
                                           checkpoint["observation_std"].numpy())
    except KeyError as error:
        raise RunError(f"checkpoint {path} lacks its entry {error}") from error
    except (TypeError, ValueError, AttributeError) as error:
        raise RunError(f"checkpoint {path} is inconsistent ({describe(error)})") from error
    if len(rows) != updates or updates < 1:
        raise RunError(f"checkpoint {path} is inconsistent: {len(rows)} log rows for {updates} updates")
    write_run_record(folder, run_record)
    return {**checkpoint, "log": [dict(row) for row in rows], "normalisation": normalisation}
