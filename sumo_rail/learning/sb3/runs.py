"""What the two Stable-Baselines3 trainers (`gail`, `ppo`) share: the install check, PPO built with a
`PolicyShape` actor, stopping after the current update on SIGINT / SIGTERM, and saving an update's policy and log
together with the checkpoint `--resume` continues from (`sb3.resume`). Stable-Baselines3 is imported only by the
functions that need it."""

from __future__ import annotations

import dataclasses
import math
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pyarrow as pa

from sumo_rail.bounds import ConfigError, bounded, check_fields, given
from sumo_rail.datasets import DatasetError, write_failure, write_parquet, written_together
from sumo_rail.drivers.policies import Policy, PolicyShape, save_policy
from sumo_rail.learning.run_folder import save_tensors, signals_ignored
from sumo_rail.learning.sb3.actor import policy_kwargs
from sumo_rail.learning.sb3.envs import LOST_ENV, close_envs, lost_env_message

if TYPE_CHECKING:
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecEnv

DEFAULT_BATCH = 64
"""PPO's minibatch size [decisions] when none is given, or an update's decisions if fewer."""
MAX_UPDATE_DECISIONS = 1_000_000
"""The most decisions an update may hold (n_steps x envs x egos): PPO keeps them all in memory."""


class BaselineError(RuntimeError):
    """A Stable-Baselines3 run cannot go on (message is one sentence)."""


@dataclass(frozen=True, kw_only=True)
class PpoSchedule:
    """The settings every PPO run has (GAIL's and the PPO driver's, which add their own and may give `timesteps` and
    `critic_warmup` other defaults), their checks, update size and count, and run.json form (stored in run.json)."""

    timesteps: int = given("--timesteps", 100_000)
    """Environment decisions in total, rounded up to whole updates of n_steps x envs."""
    kind: str = given("network.shape", "mlp")
    hidden: int = given("network.hidden", 10)
    envs: int = bounded(1, 256, default=2)
    """Environment processes, each running one SUMO; the result depends on it."""
    egos: int = bounded(1, 1000, default=1)
    """Egos per environment process (`shared_road`): PPO's envs are envs x egos; the result depends on it."""
    n_steps: int = bounded(1, MAX_UPDATE_DECISIONS, default=512)
    """Decisions per env (ego) and update; an update (n_steps x envs x egos) holds at most 1000000."""
    learning_rate: float = bounded(0, 1, default=3e-4, low_open=True)
    """PPO's Adam step size."""
    batch_size: int | None = bounded(2, MAX_UPDATE_DECISIONS, default=None, integer=True)
    """PPO minibatch size [decisions], at least 2 and at most an update's decisions; unset: DEFAULT_BATCH, or an
    update's decisions when fewer (one minibatch of the whole update, what Stable-Baselines3 does then)."""
    ppo_epochs: int = bounded(1, 1000, default=10)
    """PPO passes over each rollout."""
    gamma: float = bounded(0, 1, default=0.99, low_open=True)
    """Discount per decision (0.5 s): a horizon of about 100 decisions."""
    normalize_reward: bool = True
    """Divide PPO's rewards by the running std of the discounted return and clip them (`normalised_rewards`)."""
    critic_warmup: int = bounded(0, 100_000, default=0)
    """First updates with the actor frozen: only the critic learns (`set_actor_trainable`); they count in
    `timesteps`."""
    seed: int = given("--seed", 0)

    def check_schedule(self, section: str) -> None:
        """ConfigError naming the first setting of `section` ("gail", "ppo") out of range."""
        check_fields(self, f"{section}.")
        if self.timesteps < 1:
            raise ConfigError(f"--timesteps must be at least 1, got {self.timesteps}")
        update = f"{section}.n_steps x {section}.envs x {section}.egos"
        if self.steps_per_update < 2:
            raise ConfigError(f"an update must hold at least 2 decisions ({update}), got {self.steps_per_update}")
        if self.steps_per_update > MAX_UPDATE_DECISIONS:
            raise ConfigError(f"an update must hold at most {MAX_UPDATE_DECISIONS} decisions ({update}), got "
                              f"{self.steps_per_update}")
        if not 2 <= self.minibatch <= self.steps_per_update:
            raise ConfigError(f"{section}.batch_size must be at least 2 and at most an update's "
                              f"{self.steps_per_update} decisions ({update}), got {self.minibatch}")

    @property
    def minibatch(self) -> int:
        """PPO's minibatch size as used [decisions]: batch_size, or DEFAULT_BATCH or an update's decisions if
        fewer."""
        return self.batch_size if self.batch_size is not None else min(DEFAULT_BATCH, self.steps_per_update)

    @property
    def vec_envs(self) -> int:
        """PPO's envs: envs x egos."""
        return self.envs * self.egos

    @property
    def steps_per_update(self) -> int:
        return self.n_steps * self.vec_envs

    @property
    def updates(self) -> int:
        return math.ceil(self.timesteps / self.steps_per_update)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def require_stable_baselines3(hint: str) -> None:
    """BaselineError with `hint` (what needs it, how to install it) when Stable-Baselines3 is missing."""
    try:
        import stable_baselines3  # noqa: F401
    except ImportError as error:
        raise BaselineError(hint) from error


def build_ppo(venv: VecEnv, shape: PolicyShape, settings: PpoSchedule, ent_coef: float = 0.0) -> PPO:
    """PPO with the actor of `shape` (`actor.policy_kwargs`), seeded with `settings.seed`, on the CPU. Its
    logger keeps each update's values (`model.logger.name_to_value`) and writes nowhere: SB3's default one makes an
    empty /tmp/SB3-DATE directory at every `learn`, and the training commands call it once an update."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.logger import Logger

    model = PPO("MlpPolicy", venv, learning_rate=settings.learning_rate, n_steps=settings.n_steps,
                batch_size=settings.minibatch, n_epochs=settings.ppo_epochs, gamma=settings.gamma,
                ent_coef=ent_coef, policy_kwargs=policy_kwargs(shape), seed=settings.seed, device="cpu", verbose=0)
    model.set_logger(Logger(folder=None, output_formats=[]))
    return model


@dataclass
class EnvProcesses:
    """What `env_processes` watches: the folder env processes report failures into, and the vec env once built."""

    error_dir: Path
    venv: VecEnv | None = None


@contextmanager
def env_processes(folder: Path, run: str, updates_done: Callable[[], int]) -> Iterator[EnvProcesses]:
    """The environment processes' lifetime: a temporary folder they report failures into; on leaving, the vec env
    (`EnvProcesses.venv`, set by the caller) is closed, and a lost process (killed, crashed) becomes one
    BaselineError sentence naming it and what the run `folder` keeps after `updates_done()` updates. The closing
    ignores SIGINT and SIGTERM (a second Ctrl-C would leave it half done)."""
    with tempfile.TemporaryDirectory(prefix=f"sumo-rail-{run.lower()}-") as errors:
        processes, lost = EnvProcesses(Path(errors)), False
        try:
            yield processes
        except LOST_ENV as error:
            lost = True
            raise BaselineError(lost_env_message(processes.venv, processes.error_dir, folder, updates_done(),
                                                 run=run)) from error
        finally:
            if processes.venv is not None:
                with signals_ignored():  # a Ctrl-C after the one that stopped the run must not cut the closing
                    close_envs(processes.venv, lost)


def save_update(folder: Path, policy: Policy, rows: list[dict[str, Any]], run_record: dict[str, Any],
                checkpoint: dict[str, Any]) -> None:
    """Replace policy_latest.npz, log.parquet (`rows`, the last being this update's) and checkpoint.pt
    (`resume.learner_checkpoint`) together: all or, on a full disk, none; a BaselineError saying what the folder
    keeps otherwise."""

    update = len(rows) - 1
    try:
        with written_together(folder) as staged:
            save_policy(policy, staged.path(folder / "policy_latest.npz"), {**run_record, "iteration": update})
            write_parquet(pa.Table.from_pylist(rows), staged.path(folder / "log.parquet"),
                          {**run_record, "kind": "training_log"})
            save_tensors(checkpoint, staged.path(folder / "checkpoint.pt"))  # last: it marks the update complete
    except (OSError, DatasetError) as error:
        kept = f"it keeps update {update}, the last complete one" if update else "it holds no complete update yet"
        raise BaselineError(f"cannot save update {update + 1} in {folder} ({write_failure(error)}); {kept}: make "
                            f"room and continue with --resume") from error
