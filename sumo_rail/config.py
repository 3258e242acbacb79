"""Settings as frozen dataclasses: documented defaults, TOML overrides, validation.

Every field carries its unit in the docstring, and every number its range (`sumo_rail.bounds`: a value a road, a
car or a clock can have). `Config.from_toml` / `Config.with_overrides` reject unknown keys and impossible values
with a one-sentence `ConfigError`; `Config.to_dict` is what outputs store. The defaults
are the paper's setting; `Config.preset` gives the named settings of `PRESETS` (every command's `--preset`).
"""

from __future__ import annotations

import dataclasses
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sumo_rail.action_config import ActionConfig
from sumo_rail.bounds import ConfigError, bounded, check_fields, replace_settings

SCENARIO_KINDS = ("straight", "merge", "merge_from_ramp", "lane_drop", "exit", "network")
"""The roads of `ScenarioConfig.kind`."""
FEATURE_KINDS = ("merge", "merge_from_ramp", "lane_drop", "exit")
"""The generated roads with a feature (ramp, work zone, exit) at scenario.feature_at_m."""
FEATURE_CLEARANCE_M = 400.0
"""Least distance from a feature's end to the end of the main road [m]."""
LANE_CAPACITY_VEH_PER_H = 3000.0
"""More traffic than this a lane of the road's start is refused. SUMO lets about 1700 veh/h a lane onto a road; the
rest waits off it, so a flow up to this bound gives a road at its capacity (docs/scenarios.md, road capacity)."""
BOTTLENECK_LANE_CAPACITY_VEH_PER_H = 2000.0
"""More traffic than this a lane of a narrower part further along is refused (a work zone, a user route's narrowest
edge): there the excess jams the road itself (the work zone's lanes carry 2000 veh/h and break down at 2200)."""
EXIT_CAPACITY_VEH_PER_H = 1400.0
"""More exiting traffic than this is refused (kind exit): 1400 veh/h of 7000 exit at 24 m/s, at 1800 of 9000 the
road jams (14 m/s; experiments/road_capacity.py)."""
START_CLEARANCE_M = 200.0
"""Least distance from the ego's start window to the road's feature [m]: room to see it coming."""
WARM_UP_LIMIT_S = 200_000.0
"""The most simulated time a pool of warm states may take to build [s] (scenario.warmup_s + (scenario.snapshots - 1)
x scenario.snapshot_interval_s): about half an hour of SUMO on the default road (~120 simulated s a second), and room
for the largest pool at the default interval after the longest warm-up."""


PRESETS: dict[str, dict[str, dict[str, Any]]] = {
    "paper": {},
    "recommended": {"observation": {"lane_block": 1, "route_block": 1}},
}
"""Named settings, as changes to the defaults. paper: the defaults, the paper's setting (its 24-beam LIDAR is the
whole observation). recommended: the paper's plus the lane-wise block (observation.lane_block = 1), which shows the
learner the cars one lane over that the beams miss and that the expert reacts to, so every learner can imitate the
expert far more closely (docs/results.md, "What the learner can see"), and the route block
(observation.route_block = 1), what a navigation system tells a driver of lanes that end, merges and exits. The
benchmark's committed policies (docs/results/imitation_table) were trained before the route block existed:
evaluate them with --preset recommended --set observation.route_block=0."""


@dataclass(frozen=True)
class ScenarioConfig:
    """The road, its traffic and the SUMO options that shape them (`sumo_rail.sim.scenarios` describes each kind)."""

    kind: str = "straight"
    """The road (`SCENARIO_KINDS`): straight (the paper's), merge (an on-ramp joins on the right), merge_from_ramp
    (the same road, the ego starts on the ramp), lane_drop (a work zone where lanes end), exit (the ego's route
    leaves by an off-ramp), or network (a SUMO network of your own: scenario.network, scenario.route)."""
    length_m: float = bounded(500, 100_000, "m", default=3000.0)
    """Length of the main road [m], between 500 and 100000 m (kind network: ignored, the route's own length counts)."""
    lanes: int = bounded(1, 10, default=5)
    """Number of lanes of the main road, between 1 and 10 (lane 0 is the rightmost; kind network: the lanes of the
    route's main road, checked against the network)."""
    lane_width_m: float = bounded(2, 5, "m", default=3.2)
    """Width of each lane [m], between 2 and 5 m."""
    speed_limit_mps: float = bounded(0, 70, "m/s", default=33.33, low_open=True)
    """Speed limit of every lane [m/s] (33.33 m/s = 120 km/h), above 0 and at most 70 m/s (252 km/h)."""
    flow_veh_per_h: float = bounded(0, 30_000, "veh/h", default=4000.0, low_open=True)
    """Mean arrival rate of background traffic, all lanes together [veh/h], above 0 and at most 30000 veh/h (what
    10 lanes carry; `validate` checks the road's own lanes); arrivals are Poisson."""
    step_length_s: float = bounded(0, 1, "s", default=0.1, low_open=True)
    """SUMO simulation step [s], above 0 and at most 1 s."""
    lane_change_duration_s: float = bounded(0, 10, "s", default=2.0)
    """Time a lane change takes (SUMO --lanechange.duration) [s], between 0 and 10 s; 0 makes changes
    instantaneous."""
    teleport_time_s: float = bounded(-1, 3600, "s", default=120.0)
    """A vehicle stuck this long is teleported by SUMO (--time-to-teleport) [s], between -1 and 3600 s and not in
    (-1, 0]; -1 disables teleports."""
    collision_min_gap_factor: float = bounded(0, 1, default=0.0)
    """A collision is a gap below this fraction of minGap (--collision.mingap-factor), between 0 and 1; 0 = physical
    contact."""
    warmup_s: float = bounded(0, 3600, "s", default=300.0)
    """Simulated time before the first saved traffic state, so the ego starts in flowing traffic [s], between 0 and
    3600 s."""
    snapshots: int = bounded(1, 10_000, default=256)
    """Warm states in each pool (train, validation, test; see `sumo_rail.sim.simulation`): SUMO snapshots of the
    warmed-up traffic, between 1 and 10000; each episode starts from one (the code calls them warm states, the
    setting keeps SUMO's word). Evaluation gives episode k state k mod snapshots, so up to this many evaluation
    episodes never share a state. A pool's simulated time, warmup_s + (snapshots - 1) x snapshot_interval_s, is at
    most 200000 s (`WARM_UP_LIMIT_S`)."""
    snapshot_interval_s: float = bounded(0, 600, "s", default=10.0, low_open=True)
    """Simulated time between two saved warm states [s], above 0 and at most 600 s."""
    traffic_seed: int = bounded(0, 2**31 - 1, default=0)
    """SUMO seed of the warm-up run that produces the saved states, between 0 and 2147483647."""
    feature_at_m: float = bounded(0, 100_000, "m", default=1500.0)
    """Where the road's feature begins along the main road [m], between 0 and 100000 m: the merge's acceleration
    lane, the work zone, the exit's diverge (kinds merge, merge_from_ramp, lane_drop, exit)."""
    feature_length_m: float = bounded(50, 10_000, "m", default=300.0)
    """Length of the merge's acceleration lane and of the work zone [m], between 50 and 10000 m."""
    dropped_lanes: int = bounded(1, 9, default=2)
    """Lanes that end at the work zone, counted from the right (kind lane_drop), between 1 and 9 and fewer than
    scenario.lanes."""
    ramp_flow_veh_per_h: float = bounded(0, LANE_CAPACITY_VEH_PER_H, "veh/h", default=600.0)
    """Mean arrival rate of traffic on the on-ramp [veh/h] (kinds merge, merge_from_ramp), between 0 and 3000 veh/h
    (what its one lane carries); Poisson arrivals."""
    exit_share: float = bounded(0, 1, default=0.2, high_open=True)
    """Share of the main road's traffic that takes the exit (kind exit), at least 0 and below 1."""
    network: str = ""
    """A SUMO network file (.net.xml or .net.xml.gz) of your own (kind network), e.g. built by netconvert from
    OpenStreetMap; in a --config TOML, relative to the TOML's folder."""
    route: str = ""
    """The ego's route on scenario.network: its edge ids in order, separated by spaces (kind network)."""
    traffic_file: str = ""
    """A SUMO route file with the background traffic on scenario.network (kind network), running through the warm-up
    and its snapshots (docs/scenarios.md); empty: a flow of scenario.flow_veh_per_h along the ego's route, with the
    types of the built-in roads."""

    @property
    def has_route_measures(self) -> bool:
        """Whether episodes on this road report the route's measures (merges, missed exits, lane-end stops) even
        when none happened: every road but the straight one."""
        return self.kind != "straight"

    def validate(self) -> None:
        _require(self.kind in SCENARIO_KINDS,
                 f"unknown scenario.kind {self.kind!r}; known: {', '.join(SCENARIO_KINDS)}")
        self._validate_feature()
        _require(self.flow_veh_per_h <= LANE_CAPACITY_VEH_PER_H * self.lanes,
                 f"scenario.flow_veh_per_h ({self.flow_veh_per_h:g} veh/h) is more than {self.lanes} lanes can carry "
                 f"(about {LANE_CAPACITY_VEH_PER_H:g} veh/h a lane)")
        self._validate_bottleneck()
        _require(self.teleport_time_s == -1 or self.teleport_time_s > 0,
                 f"scenario.teleport_time_s must be positive or -1, got {self.teleport_time_s}")
        warm_up_s = self.warmup_s + (self.snapshots - 1) * self.snapshot_interval_s
        _require(warm_up_s <= WARM_UP_LIMIT_S,
                 f"scenario.warmup_s + (scenario.snapshots - 1) x scenario.snapshot_interval_s ({warm_up_s:.0f} s) "
                 f"must be at most {WARM_UP_LIMIT_S:.0f} s, the simulated time of a pool of warm states (about half "
                 f"an hour of SUMO)")

    def _validate_bottleneck(self) -> None:
        """The traffic fits the road's narrowest part: the work zone's lanes, the exit's off-ramp, or the main road
        past the merge."""
        if self.kind == "lane_drop":
            zone_lanes = self.lanes - self.dropped_lanes
            _require(self.flow_veh_per_h <= BOTTLENECK_LANE_CAPACITY_VEH_PER_H * zone_lanes,
                     f"scenario.flow_veh_per_h ({self.flow_veh_per_h:g} veh/h) is more than the work zone's "
                     f"{zone_lanes} lane{'s' if zone_lanes > 1 else ''} can carry "
                     f"(about {BOTTLENECK_LANE_CAPACITY_VEH_PER_H:g} veh/h a lane)")
        if self.kind == "exit":
            exiting = self.flow_veh_per_h * self.exit_share
            _require(exiting <= EXIT_CAPACITY_VEH_PER_H,
                     f"scenario.flow_veh_per_h times scenario.exit_share ({exiting:g} veh/h) is more than the exit "
                     f"takes (about {EXIT_CAPACITY_VEH_PER_H:g} veh/h through its one-lane off-ramp)")
        if self.kind in ("merge", "merge_from_ramp"):
            total = self.flow_veh_per_h + self.ramp_flow_veh_per_h
            _require(total <= LANE_CAPACITY_VEH_PER_H * self.lanes,
                     f"scenario.flow_veh_per_h plus scenario.ramp_flow_veh_per_h ({total:g} veh/h) is more than the "
                     f"{self.lanes} lanes past the merge can carry (about {LANE_CAPACITY_VEH_PER_H:g} veh/h a lane)")

    def _validate_feature(self) -> None:
        """The feature's settings: on the road, before its end, with lanes left over."""
        if self.kind == "lane_drop":
            _require(1 <= self.dropped_lanes < self.lanes,
                     f"scenario.dropped_lanes must be between 1 and scenario.lanes - 1 ({self.lanes - 1}), "
                     f"got {self.dropped_lanes}")
        if self.kind in FEATURE_KINDS:
            end_m = self.feature_at_m + (0.0 if self.kind == "exit" else self.feature_length_m)
            _require(200.0 <= self.feature_at_m and end_m + FEATURE_CLEARANCE_M <= self.length_m,
                     f"the {self.kind} scenario's feature ({self.feature_at_m:g} m to {end_m:g} m) must lie between "
                     f"200 m and {FEATURE_CLEARANCE_M:g} m before the road's end at {self.length_m:g} m; "
                     f"change scenario.feature_at_m, scenario.feature_length_m or scenario.length_m")
        if self.kind == "network":
            _require(bool(self.network), "scenario.kind network needs scenario.network, the path of a .net.xml")
            _require(bool(self.route.split()), "scenario.kind network needs scenario.route, the ego's edge ids")
        given = [name for name in ("network", "route", "traffic_file") if getattr(self, name)]
        _require(self.kind == "network" or not given,
                 f"scenario.{' and scenario.'.join(given)} only serve{'s' if len(given) == 1 else ''} scenario.kind "
                 f"network, not {self.kind}; drop {'it' if len(given) == 1 else 'them'} or set scenario.kind=network")


@dataclass(frozen=True)
class LidarConfig:
    """The virtual 360-degree LIDAR mounted at the ego's centre."""

    beams: int = bounded(4, 360, default=24)
    """Number of beams, between 4 and 360 and dividing 360, evenly spread over 360 degrees; beam 0 points straight
    ahead, counter-clockwise."""
    range_m: float = bounded(0, 1000, "m", default=100.0, low_open=True)
    """Maximum range r_max [m], above 0 and at most 1000 m; a beam that hits nothing returns it."""

    @property
    def beam_spacing_deg(self) -> float:
        """Angle between neighbouring beams [deg]."""
        return 360.0 / self.beams

    def validate(self) -> None:
        _require(360 % self.beams == 0, f"lidar.beams must divide 360 degrees evenly, got {self.beams}")


@dataclass(frozen=True)
class ObservationConfig:
    """What the learner sees besides the LIDAR (see `sumo_rail.sim.observation`)."""

    lane_block: int = bounded(0, 1, default=0)
    """0 or 1. 1: append 12 lane-wise values (gap and relative speed of the nearest vehicle ahead and behind in the
    ego's lane and each neighbouring lane, within lidar.range_m); 0: the paper's LIDAR-only observation."""

    route_block: int = bounded(0, 1, default=0)
    """0 or 1. 1: append 4 route values, what a navigation system tells a driver (`sumo_rail.sim.route_progress`):
    how far the ego's lane leads along its route, the lanes to move to the nearest lane that leads farthest, and the
    distances to the next merge and the next diverge (exit), each within observation.route_range_m; 0: without
    them."""
    route_range_m: float = bounded(0, 5000, "m", default=500.0, low_open=True)
    """How far ahead the route block looks [m], above 0 and at most 5000 m: lanes to cross before a lane's end need
    a few hundred metres."""
    history: int = bounded(0, 10, default=0)
    """Seconds of the ego's own past the observation shows, between 0 and 10: 1 to 10 append, for each second back,
    the ego's speed, acceleration and the lanes it has moved since (`sumo_rail.sim.ego_past`), from which a learner
    can tell a recorded driver's desired speed and style; 0: none (the paper's)."""


@dataclass(frozen=True)
class ExpertConfig:
    """What the rule-based expert sees."""

    view_range_m: float = bounded(0, 1000, "m", default=120.0, low_open=True)
    """The expert ignores vehicles whose front is farther than this along the road from the ego's [m], above 0 and
    at most 1000 m. 120 m is everything the environment queries (lidar.range_m + 20 m); lidar.range_m limits it to
    the sensor's reach."""


@dataclass(frozen=True)
class EnvConfig:
    """The ego's decisions, actions, rewards and episode limits."""

    decision_period_s: float = bounded(0, 10, "s", default=0.5, low_open=True)
    """Simulated time between two decisions [s], above 0 and at most 10 s; a multiple of the SUMO step (default 5
    steps of 0.1 s)."""
    v_min_mps: float = bounded(0, 70, "m/s", default=10.0)
    """Lowest cruise set-point and zero of the longitudinal reward [m/s], between 0 and 70 m/s, below v_max_mps."""
    v_max_mps: float = bounded(0, 70, "m/s", default=33.33, low_open=True)
    """Highest cruise set-point and one of the longitudinal reward [m/s], above 0 and at most 70 m/s."""
    speed_step_mps: float = bounded(0, 10, "m/s", default=2.0, low_open=True)
    """Change of the cruise set-point per accelerate/decelerate action [m/s], above 0 and at most 10 m/s."""
    hard_brake_mps2: float = bounded(0, 15, "m/s^2", default=4.0, low_open=True)
    """A decision whose ego deceleration exceeds this at any step counts as hard braking [m/s^2], above 0 and at
    most 15 m/s^2."""
    lane_change_reward: float = bounded(-100, 100, default=-0.5)
    """Lateral reward per decision during which a lane change is in progress, between -100 and 100 (the speed
    reward of a decision is between 0 and 1)."""
    collision_reward: float = bounded(-1000, 0, default=-10.0)
    """Reward of the decision in which the ego collides (the episode then terminates), between -1000 and 0."""
    max_episode_s: float = bounded(0, 3600, "s", default=300.0, low_open=True)
    """Simulated time after which the episode is truncated [s], above 0 and at most 3600 s."""
    end_margin_m: float = bounded(0, 10_000, "m", default=100.0)
    """The episode is truncated when the ego's front is this close to the end of the road [m], between 0 and
    10000 m."""
    ego_start_min_m: float = bounded(0, 100_000, "m", default=300.0)
    """Nearest start position of the ego's front from the start of the road [m], between 0 and 100000 m."""
    ego_start_max_m: float = bounded(0, 100_000, "m", default=700.0)
    """Farthest start position of the ego's front from the start of the road [m], between 0 and 100000 m."""
    zip_merge_m: float = bounded(0, 1000, "m", default=250.0)
    """Within this distance of the end of a lane that does not lead along its route, the ego's lane changes toward
    the lanes that do are zip merges: SUMO makes them when no collision is immediate and the followers brake, as
    its own drivers merge at a lane's end; elsewhere they wait for SUMO's safe gaps [m], between 0 and 1000 m."""

    def steps_per_decision(self, step_length_s: float) -> int:
        """SUMO steps in one decision period."""
        return round(self.decision_period_s / step_length_s)

    def validate(self, scenario: ScenarioConfig) -> None:
        steps = self.decision_period_s / scenario.step_length_s
        _require(self.decision_period_s > 0 and abs(steps - round(steps)) < 1e-6 and round(steps) >= 1,
                 f"env.decision_period_s must be a positive multiple of the {scenario.step_length_s} s step, "
                 f"got {self.decision_period_s}")
        _require(0 <= self.v_min_mps < self.v_max_mps,
                 f"env.v_min_mps and env.v_max_mps must satisfy 0 <= v_min < v_max, got {self.v_min_mps} and "
                 f"{self.v_max_mps}")
        _require(self.max_episode_s >= self.decision_period_s,
                 f"env.max_episode_s must be at least one decision period, got {self.max_episode_s}")
        _require(0 <= self.ego_start_min_m <= self.ego_start_max_m,
                 f"env.ego_start_min_m must be between 0 and env.ego_start_max_m, got {self.ego_start_min_m}")
        _require(scenario.kind == "network" or self.ego_start_max_m + self.end_margin_m < scenario.length_m,
                 f"env.ego_start_max_m + env.end_margin_m must be shorter than the road "
                 f"({scenario.length_m} m), got {self.ego_start_max_m + self.end_margin_m}")
        if scenario.kind in FEATURE_KINDS:
            _require(self.ego_start_max_m + START_CLEARANCE_M <= scenario.feature_at_m,
                     f"env.ego_start_max_m ({self.ego_start_max_m:g} m) must end at least {START_CLEARANCE_M:g} m "
                     f"before the {scenario.kind} scenario's feature at scenario.feature_at_m "
                     f"({scenario.feature_at_m:g} m)")


@dataclass(frozen=True)
class Config:
    """Everything that defines the simulated driving task."""

    scenario: ScenarioConfig = field(default_factory=ScenarioConfig)
    lidar: LidarConfig = field(default_factory=LidarConfig)
    env: EnvConfig = field(default_factory=EnvConfig)
    observation: ObservationConfig = field(default_factory=ObservationConfig)
    expert: ExpertConfig = field(default_factory=ExpertConfig)
    actions: ActionConfig = field(default_factory=ActionConfig)

    def __post_init__(self) -> None:
        check_fields(self)
        self.scenario.validate()
        self.lidar.validate()
        self.env.validate(self.scenario)
        self.actions.validate()

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Plain nested dict of every setting, as stored with outputs."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Config:
        """Build from a nested mapping of sections; unknown sections or keys raise ConfigError."""
        return cls().with_overrides(data)

    @classmethod
    def from_toml(cls, path: str | Path) -> Config:
        """Read a TOML file with optional [scenario], [lidar], [env], [observation], [expert] and [actions] tables."""
        return cls().with_toml(path)

    @classmethod
    def preset(cls, name: str) -> Config:
        """The named setting `name` of PRESETS; an unknown name raises ConfigError."""
        _require(name in PRESETS, f"unknown preset {name!r}; known: {', '.join(PRESETS)}")
        return cls.from_dict(PRESETS[name])

    def with_toml(self, path: str | Path) -> Config:
        """A copy with the keys of a TOML file's tables replaced (the format of `from_toml`)."""
        return self.with_overrides(read_config_file(path))

    @classmethod
    def coerce(cls, value: Config | Mapping[str, Any] | str | Path | None) -> Config:
        """A Config from what a user may hand to `gymnasium.make(ENV_ID, config=...)`: None (the defaults), a
        Config, a nested mapping `{section: {key: value}}` or the path of a TOML file; anything else, like a bad
        value, raises a one-sentence ConfigError."""
        if value is None:
            return cls()
        if isinstance(value, Config):
            return value
        if isinstance(value, Mapping):
            return cls.from_dict(value)
        if isinstance(value, str | Path):
            return cls.from_toml(value)
        raise ConfigError(f"config must be a Config, a nested dict of sections or the path of a TOML file, "
                          f"got {type(value).__name__}")

    def with_overrides(self, data: Mapping[str, Any]) -> Config:
        """A copy with `{section: {key: value}}` replaced; unknown sections/keys and bad types raise."""
        sections = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        unknown = sorted(set(data) - set(sections))
        _require(not unknown, f"unknown config section(s) {unknown}; known: {sorted(sections)}")
        updated = {}
        for name, current in sections.items():
            values = data.get(name, {})
            _require(isinstance(values, Mapping), f"config section [{name}] must be a table, got {values!r}")
            updated[name] = replace_settings(name, current, values)
        return Config(**updated)


SECTIONS = tuple(item.name for item in dataclasses.fields(Config))
"""The simulation's sections of a --config file; the learners' are `sumo_rail.learning.settings.SECTIONS`."""


def read_config_file(path: str | Path) -> dict[str, Any]:
    """The tables of a --config TOML file, scenario.network and scenario.traffic_file made relative to the file's
    folder; an unreadable file is a one-sentence ConfigError."""
    try:
        with open(path, "rb") as handle:
            data = tomllib.load(handle)
    except OSError as error:
        raise ConfigError(f"cannot read config file {path}: {error.strerror or error}") from error
    except UnicodeDecodeError as error:
        byte = error.object[error.start]
        raise ConfigError(f"config file {path} is not UTF-8 text, as TOML must be (byte 0x{byte:02x} at offset "
                          f"{error.start})") from error
    except tomllib.TOMLDecodeError as error:
        raise ConfigError(f"config file {path} is not valid TOML: {error}") from error
    scenario = data.get("scenario")
    for key in ("network", "traffic_file"):  # a file named in the TOML is found from the TOML's folder
        if isinstance(scenario, dict) and isinstance(scenario.get(key), str) and scenario[key]:
            scenario[key] = str(Path(path).parent / Path(scenario[key]).expanduser())
    return data


def _require(condition: bool, message: str) -> None:
    if not condition:
        raise ConfigError(message)
