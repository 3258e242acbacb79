"""Who the expert is: a style of the rule-based driver or any saved policy file, named by one string.

The expert is whoever can be asked what it would do at a decision: the rule-based driver of a style reads the traffic
view, a policy file reads the observation (so its observation layout must be the environment's). `resolve_expert`
turns the string a user gives (`--expert normal`, `--expert runs/ppo/policy_latest.npz`) into a picklable driver
recipe. Outputs record the expert as `expert_reference` writes it (`expert` in run.json and the Parquet metadata): a
style, or a policy file's absolute path and content hash ("/abs/exp.npz#sha256=HEX"), so a later command, from any
folder, asks the same expert again or says in one sentence that the file is gone or changed.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from sumo_rail.config import Config
from sumo_rail.datasets import DatasetError, file_sha256
from sumo_rail.drivers.expert import DEFAULT_STYLE, STYLES
from sumo_rail.drivers.policies import PolicyFileError, PolicyInterfaceError, load_policy
from sumo_rail.runners.rollout import DriverSpec, ExpertDriver, PolicyDriver
from sumo_rail.sim.actions import action_count
from sumo_rail.sim.observation import observation_names

SAMPLED_SUFFIX = " (sampled)"
"""Ends the table name of a policy evaluated by sampling."""

LAYOUT_SETTINGS = (("lidar", "beams"), ("scenario", "lanes"), ("observation", "lane_block"))
"""The settings that shape the observation layout (`observation_names`)."""
INTERFACE_SETTINGS = (("actions", "interface"), ("actions", "acceleration_min_mps2"),
                      ("actions", "acceleration_max_mps2"), ("actions", "acceleration_bin_mps2"))
"""The settings that shape the action space (`action_space_of`)."""
SCALE_SETTINGS = (("lidar", "range_m"), ("env", "v_max_mps"), ("env", "v_min_mps"))
"""The settings that scale the observation's values (`build_observation`): the same layout with other values of them
means other inputs to a policy."""


def policy_name(path: Path) -> str:
    """A policy file's name in tables: RUN/STEM for a file of a training run folder (it holds run.json), so
    runs/a/policy_bc.npz and runs/b/policy_bc.npz stay apart; the file's stem otherwise."""
    return f"{path.parent.resolve().name}/{path.stem}" if (path.parent / "run.json").is_file() else path.stem


def parse_policy(path: Path, config: Config, sampled: bool = False, name: str | None = None) -> PolicyDriver:
    """The saved policy file at `path` as a driver named `name` (default `policy_name`), after checking that it
    chooses among the configuration's actions (else a PolicyInterfaceError) and reads the environment's observation
    layout. It decodes its logits by `config`'s actions.decoding, whatever decoding its
    file records (the run says how its policies act; a name not decoding by argmax ends in " (DECODING)"); `sampled`:
    it draws its actions from the softmax of its logits at actions.sampling_temperature instead, and its name ends in
    " (sampled)" (" (sampled at T)" at a temperature T below 1). Its `expert` is
    the expert its file records."""
    policy, metadata = load_policy(path)
    if policy.shape.actions != (count := action_count(config.actions)):  # first: the interface shapes the layout too
        trained = differing_settings(metadata, config, INTERFACE_SETTINGS)
        raise PolicyInterfaceError(f"policy {path} chooses among {policy.shape.actions} actions but this "
                                   f"configuration's action interface has {count} (actions.interface="
                                   f"{config.actions.interface}){trained}")
    expected = observation_names(config)
    if policy.shape.observation_size != len(expected):
        raise PolicyFileError(f"policy {path} reads {policy.shape.observation_size} observation values but this "
                              f"configuration's observation has {len(expected)}{differing_settings(metadata, config)}")
    stored = metadata.get("observation_names")
    if stored is not None and list(stored) != expected:
        first = next(index for index, (mine, theirs) in enumerate(zip(stored, expected, strict=True))
                     if mine != theirs)
        raise PolicyFileError(f"policy {path} reads another observation layout than this configuration's (value "
                              f"{first} is {stored[first]!r} there and {expected[first]!r} here)"
                              f"{differing_settings(metadata, config)}")
    if scales := differing_settings(metadata, config, SCALE_SETTINGS):
        raise PolicyFileError(f"policy {path} reads observations scaled otherwise than this configuration's{scales}")
    decoding = config.actions.decoding
    policy = policy.decoded_by(decoding)
    temperature = config.actions.sampling_temperature
    suffix = ("" if decoding == "argmax" else f" ({decoding})") if not sampled else \
        SAMPLED_SUFFIX if temperature == 1 else f" (sampled at {temperature:g})"
    return PolicyDriver(policy, (name or policy_name(path)) + suffix, expert=recorded_expert(metadata),
                        sampled=sampled, temperature=temperature)


def differing_settings(metadata: Mapping[str, Any], config: Config,
                       settings: tuple[tuple[str, str], ...] = LAYOUT_SETTINGS) -> str:
    """The `settings` where the training configuration a policy file records differs from `config`, as
    "; it was trained with --set observation.lane_block=1 and this configuration has observation.lane_block=0";
    "" when they agree or the file records no configuration."""
    trained, here = metadata.get("config"), config.to_dict()
    if not isinstance(trained, Mapping):
        return ""
    differing = [(f"{section}.{key}", trained[section][key], here[section][key]) for section, key in settings
                 if isinstance(trained.get(section), Mapping) and key in trained[section]
                 and trained[section][key] != here[section][key]]
    if not differing:
        return ""
    return ("; it was trained with " + " ".join(f"--set {name}={theirs}" for name, theirs, _ in differing)
            + " and this configuration has " + " ".join(f"{name}={mine}" for name, _, mine in differing))


PINNED = "#sha256="
"""Separates a recorded policy-file expert's absolute path from the SHA-256 of its content."""


def expert_reference(expert: str) -> str:
    """How outputs record the expert named `expert`: a style as it is, a policy file as its absolute path and content
    hash (`PINNED`); an already recorded one unchanged. A name that is neither is a ValueError listing the styles."""
    if expert in STYLES or PINNED in expert:
        return expert
    path = _expert_path(expert)
    if not path.is_file():
        raise PolicyFileError(f"policy file {path} does not exist")
    return f"{path.resolve()}{PINNED}{_content_hash(path)}"


def resolve_expert(expert: str, config: Config, recorded_by: Path | str | None = None) -> DriverSpec:
    """The expert named `expert` (as typed, or as `expert_reference` recorded it in the file `recorded_by`): a style
    of the rule-based driver (`ExpertDriver`, named expert-STYLE), or a policy file (`parse_policy`, named
    expert-NAME, whose own expert is itself even when its file records another). An unknown name is a ValueError
    listing the styles; a recorded policy file that is gone or whose content changed is a PolicyFileError naming
    `recorded_by`."""
    if expert in STYLES:
        return ExpertDriver(expert)
    text, _, digest = expert.partition(PINNED)
    try:
        path = _expert_path(text)
    except ValueError as error:
        if recorded_by is None:
            raise
        raise PolicyFileError(f"{recorded_by} records the expert {expert!r}, which is neither a style "
                              f"({', '.join(sorted(STYLES))}) nor a policy file") from error
    recorded = f", which {recorded_by} records as its expert," if recorded_by is not None else ""
    if recorded and not path.is_file():
        raise PolicyFileError(f"the policy file {path}{recorded} does not exist")
    if digest and path.is_file() and _content_hash(path) != digest:
        raise PolicyFileError(f"the policy file {path}{recorded or ' (a recorded expert)'} has changed since it was "
                              f"recorded (its content hash differs)")
    # its reference is itself (it is the expert), not the expert its file records it learned from
    return dataclasses.replace(parse_policy(path, config, name=f"expert-{policy_name(path)}"), expert=expert)


def check_drives(expert: DriverSpec, config: Config) -> None:
    """A ValueError when `expert` cannot drive or label under `config`'s action interface: the rule-based expert
    decides the paper's five actions only (asked for agreement it may be under any interface: a driver's action then
    counts as the paper action it amounts to, `evaluation.fidelity.AgreementObserver`)."""
    if isinstance(expert, ExpertDriver) and config.actions.interface != "paper":
        raise ValueError(f"the rule-based expert ({expert.style!r}) decides the paper's five actions only; with "
                         f"actions.interface={config.actions.interface} the expert that drives or labels must be a "
                         f"policy file of that interface")


def _expert_path(expert: str) -> Path:
    """The policy file an expert name that is not a style means; a ValueError when it cannot be one."""
    path = Path(expert)
    if not expert.strip() or path.is_dir() or (not path.suffix and not path.exists()):
        raise ValueError(f"unknown expert {expert!r}: not a style ({', '.join(sorted(STYLES))}) nor a policy file")
    return path


def _content_hash(path: Path) -> str:
    """SHA-256 of the file's bytes, in hex."""
    return file_sha256(path)


def recorded_expert(metadata: Mapping[str, Any]) -> str | None:
    """The expert an output's metadata records (`expert`, or `expert_style` / `style` in files written before any
    driver could be the expert), or None."""
    for key in ("expert", "expert_style", "style"):
        if isinstance(metadata.get(key), str):
            return str(metadata[key])
    return None


RECORDED_SCENE = "recorded_scene"
"""The metadata key of demonstrations read from a recorded scene (`recordings.recorded_demos`): what they came from."""


class NotQueryable(DatasetError):
    """Demonstrations of recorded drivers given where an expert must be asked at new states."""


def demonstrations_expert(metadata: Mapping[str, Any], recorded_stand_in: str | None = None) -> str:
    """Who a demonstrations file recorded (its metadata), the default style for a file that does not say. A file read
    from a recorded scene has no expert to ask: NotQueryable, unless `recorded_stand_in` names the driver that
    stands in for it (the rule-based style RAIL's agreement measures ask)."""
    scene = metadata.get(RECORDED_SCENE)
    if isinstance(scene, Mapping):
        if recorded_stand_in is not None:
            return recorded_stand_in
        raise NotQueryable(f"these demonstrations were read from the recorded scene {scene.get('folder')}: a "
                           f"recorded driver cannot be asked what it would do at the states another driver reaches, "
                           f"so DAgger with an expert, DART and agreement with the expert do not apply (train BC, RAIL "
                           f"or GAIL, or DAgger against the log: --expert log)")
    return recorded_expert(metadata) or DEFAULT_STYLE
