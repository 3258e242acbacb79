"""Linear and two-layer policies as flat float32 parameter vectors with a fast numpy `act`, and their file format.

Parameter layout (row-major), for n observations, h hidden units and a = 5 actions:
- linear: W (a, n), b (a); logits = W x + b;
- mlp: W1 (h, n), b1 (h), W2 (a, h), b2 (a); logits = W2 tanh(W1 x + b1) + b2;
where x = (observation - mean) / std is the observation normalised by the statistics frozen in the policy.

A policy file is a NumPy `.npz` archive read with `allow_pickle=False` (no code can run on load) holding:
`format` ("sumo-rail policy"), `format_version`, `kind`, `observation_size`, `hidden`, `actions`,
`parameters` (float32), `observation_mean`, `observation_std` (float64), `metadata` (a JSON string:
observation names, config, provenance) and, for a policy that does not act by argmax, `decoding` (a file without it,
as every file written before it existed, acts by argmax).
"""

from __future__ import annotations

import dataclasses
import json
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sumo_rail.datasets import describe, written_atomically
from sumo_rail.drivers.decoding import check_decoding, decode

FORMAT = "sumo-rail policy"
FORMAT_VERSION = 1
KINDS = ("linear", "mlp")
MIN_STD = 1e-6
"""Smallest observation std a policy divides by; constant features are not blown up."""


class PolicyFileError(ValueError):
    """A policy file is missing, unreadable or inconsistent (message is one sentence)."""


class PolicyInterfaceError(PolicyFileError):
    """A readable policy file of another action interface than the run's: a usage error (the CLI's exit 2)."""


@dataclass(frozen=True)
class PolicyShape:
    """The architecture of a policy."""

    kind: str
    """'linear' or 'mlp' (two layers, tanh hidden units)."""
    observation_size: int
    hidden: int = 10
    """Hidden units of the 'mlp' kind (ignored for 'linear')."""
    actions: int = 5
    decoding: str = "argmax"
    """How `Policy.act` reads the logits (`sumo_rail.drivers.decoding`): the run's actions.decoding."""

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"policy kind must be one of {', '.join(KINDS)}, got {self.kind!r}")
        if self.observation_size < 1 or self.actions < 1 or (self.kind == "mlp" and self.hidden < 1):
            raise ValueError(f"policy sizes must be positive, got {self}")
        check_decoding(self.decoding, self.actions)

    @property
    def parameter_count(self) -> int:
        n, h, a = self.observation_size, self.hidden, self.actions
        return a * n + a if self.kind == "linear" else h * n + h + a * h + a


class Policy:
    """A policy on the logits of the normalised observation: `act(observation)` decodes them by its shape's decoding
    (their argmax unless told otherwise; deterministic), `sample(observation, rng)` draws from their softmax (the
    stochastic policy PPO trains)."""

    def __init__(self, shape: PolicyShape, parameters: np.ndarray, observation_mean: np.ndarray | None = None,
                 observation_std: np.ndarray | None = None) -> None:
        parameters = np.asarray(parameters, dtype=np.float32).ravel()
        if parameters.size != shape.parameter_count:
            raise ValueError(f"a {shape.kind} policy for {shape.observation_size} observations needs "
                             f"{shape.parameter_count} parameters, got {parameters.size}")
        n = shape.observation_size
        mean = np.zeros(n) if observation_mean is None else np.asarray(observation_mean, dtype=np.float64)
        std = np.ones(n) if observation_std is None else np.asarray(observation_std, dtype=np.float64)
        if mean.shape != (n,) or std.shape != (n,):
            raise ValueError(f"normalisation statistics must have shape ({n},), got {mean.shape} and {std.shape}")
        self.shape = shape
        self.parameters = parameters
        self.observation_mean = mean
        self.observation_std = std
        self._scale = 1.0 / np.maximum(std, MIN_STD)
        self._layers = _unflatten(shape, parameters)

    def logits(self, observations: np.ndarray) -> np.ndarray:
        """Logits for one observation (shape (n,)) or a batch (shape (B, n))."""
        x = (np.asarray(observations, dtype=np.float64) - self.observation_mean) * self._scale
        if self.shape.kind == "linear":
            weights, bias = self._layers
            return x @ weights.T + bias
        w1, b1, w2, b2 = self._layers
        return np.tanh(x @ w1.T + b1) @ w2.T + b2

    def act(self, observation: np.ndarray) -> int:
        """The action of the logits under the shape's decoding (argmax: the highest logit, ties the lowest index)."""
        return int(decode(self.logits(observation), self.shape.decoding))

    def acts(self, observations: np.ndarray) -> np.ndarray:
        """`act` of each row of a batch of observations (shape (B, n)), shape (B,)."""
        return decode(self.logits(observations), self.shape.decoding)

    def decoded_by(self, decoding: str) -> Policy:
        """This policy acting by `decoding` (the same parameters and normalisation; `sumo_rail.drivers.decoding`)."""
        return Policy(dataclasses.replace(self.shape, decoding=decoding), self.parameters, self.observation_mean,
                      self.observation_std)

    def probabilities(self, observations: np.ndarray, temperature: float = 1.0) -> np.ndarray:
        """Softmax of the logits divided by `temperature`, for one observation (shape (a,)) or a batch (shape
        (B, a))."""
        logits = self.logits(observations)
        with np.errstate(over="ignore"):  # the maximum first (logits / T overflow at a tiny T): the others go to -inf
            exponentials = np.exp((logits - logits.max(axis=-1, keepdims=True)) / temperature)
        return exponentials / exponentials.sum(axis=-1, keepdims=True)

    def sample(self, observation: np.ndarray, rng: np.random.Generator, temperature: float = 1.0) -> int:
        """An action drawn from the softmax of the logits over `temperature` with `rng` (one uniform number per
        call)."""
        return int(rng.choice(self.shape.actions, p=self.probabilities(observation, temperature)))

    def __getstate__(self) -> dict[str, Any]:
        return {"shape": self.shape, "parameters": self.parameters, "mean": self.observation_mean,
                "std": self.observation_std}

    def __setstate__(self, state: dict[str, Any]) -> None:
        type(self).__init__(self, state["shape"], state["parameters"], state["mean"], state["std"])


def _unflatten(shape: PolicyShape, parameters: np.ndarray) -> tuple[np.ndarray, ...]:
    """Weight matrices and biases (float64 views for the matrix products) in the documented layout."""
    n, h, a = shape.observation_size, shape.hidden, shape.actions
    sizes = [(a, n), (a,)] if shape.kind == "linear" else [(h, n), (h,), (a, h), (a,)]
    values = parameters.astype(np.float64)
    layers, offset = [], 0
    for size in sizes:
        count = int(np.prod(size))
        layers.append(values[offset:offset + count].reshape(size))
        offset += count
    return tuple(layers)


def save_policy(policy: Policy, path: Path, metadata: dict[str, Any]) -> None:
    """Write the policy file atomically (`written_atomically`)."""
    decoding: dict[str, Any] = ({} if policy.shape.decoding == "argmax"
                                else {"decoding": np.array(policy.shape.decoding)})  # argmax files as before
    with written_atomically(path) as temporary, open(temporary, "wb") as handle:
        np.savez(handle, **decoding, format=np.array(FORMAT), format_version=np.array(FORMAT_VERSION),
                 kind=np.array(policy.shape.kind), observation_size=np.array(policy.shape.observation_size),
                 hidden=np.array(policy.shape.hidden), actions=np.array(policy.shape.actions),
                 parameters=policy.parameters, observation_mean=policy.observation_mean,
                 observation_std=policy.observation_std, metadata=np.array(json.dumps(metadata, sort_keys=True)))


def load_policy(path: Path) -> tuple[Policy, dict[str, Any]]:
    """Read and validate a policy file; returns the policy and its metadata. Never unpickles. Any missing, empty,
    truncated, damaged, foreign or inconsistent file is a PolicyFileError naming it, in one sentence."""
    path = Path(path)
    if not path.is_file():
        raise PolicyFileError(f"policy file {path} does not exist")
    if path.stat().st_size == 0:
        raise PolicyFileError(f"policy file {path} is empty (0 bytes)")
    if not zipfile.is_zipfile(path):
        raise PolicyFileError(f"{path} is not a readable sumo-rail policy file (not an .npz archive: truncated, "
                              f"overwritten or another kind of file)")
    try:
        with np.load(path, allow_pickle=False) as archive:
            fields = {key: archive[key] for key in archive.files}
    except ValueError as error:
        if "allow_pickle" in str(error):
            raise PolicyFileError(f"{path} holds pickled objects, which a policy file never does (sumo-rail does not "
                                  f"unpickle)") from error
        raise PolicyFileError(f"{path} is not a readable sumo-rail policy file ({describe(error)})") from error
    except (OSError, zipfile.BadZipFile, EOFError, UnicodeDecodeError) as error:
        raise PolicyFileError(f"{path} is not a readable sumo-rail policy file ({describe(error)})") from error
    except Exception as error:  # zlib.error and others from a damaged archive
        raise PolicyFileError(f"{path} is a damaged policy file ({describe(error)})") from error
    if not isinstance(fields, dict) or str(fields.get("format", "")) != FORMAT:
        raise PolicyFileError(f"{path} is not a sumo-rail policy file (no '{FORMAT}' format marker)")
    try:
        version = int(fields["format_version"])
    except (KeyError, TypeError, ValueError) as error:
        raise PolicyFileError(f"policy file {path} has no readable format version") from error
    if version != FORMAT_VERSION:
        raise PolicyFileError(f"{path} has policy format version {version}; this sumo-rail reads version "
                              f"{FORMAT_VERSION}")
    try:
        shape = PolicyShape(str(fields["kind"]), int(fields["observation_size"]), int(fields["hidden"]),
                            int(fields["actions"]), str(fields.get("decoding", "argmax")))
        policy = Policy(shape, fields["parameters"], fields["observation_mean"], fields["observation_std"])
        metadata = json.loads(str(fields["metadata"]))
    except KeyError as error:
        raise PolicyFileError(f"policy file {path} lacks the field {error}") from error
    except (ValueError, TypeError) as error:
        raise PolicyFileError(f"policy file {path} is inconsistent: {describe(error)}") from error
    if not isinstance(metadata, dict):
        raise PolicyFileError(f"policy file {path} has metadata that is not a JSON object")
    if not (np.all(np.isfinite(policy.parameters)) and np.all(np.isfinite(policy.observation_mean))
            and np.all(np.isfinite(policy.observation_std))):
        raise PolicyFileError(f"policy file {path} holds non-finite parameters")
    return policy, metadata
