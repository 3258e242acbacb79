"""SUMO's IDM calibrated on a scene's train split: the strong baseline in a recorded seat (`sumo-idm-calibrated`).

What is fitted: the five IDM parameters of `idm.IdmParameters` (accel, decel, tau, minGap, delta) within `BOUNDS`,
one set for the scene's train drivers of one class (passenger cars by default; evaluate-scene fits one for each class
of its seats), and with them
each train driver's desired speed v0, which IDM needs and no recording names.

On what (`idm_windows`): windows of `horizon_s` from every `sample_s` of each train track (or of its span `span_s`
after the track begins: evaluate-scene fits the train seats, where it seats the held-out drivers) in which the driver
keeps its lane and follows one leader (or none). `idm.simulate` drives the driver from its recorded speed and gap,
SUMO's step after step, behind its leader moving as recorded. `fit`: Levenberg-Marquardt on the differences between
the simulated and the recorded speeds at every step of every window, parameters and desired speeds at once, from
SUMO's defaults, with a Cauchy loss of scale `loss_scale_mps`: what no car-following model explains (a driver slowing
to let another in, or not to pass a slower car on its left, as SUMO's LC2013 and European law have it) falls far
outside that scale and barely pulls the fit. On tracks made by the same formula it recovers the parameters and
desired speeds exactly; on SUMO's own IDM drivers accel, decel, tau and delta within 5% (tests).

Desired speed (`read_desired_speeds`) under given parameters: the lowest that fits the driver's windows within
`DESIRED_TOLERANCE_MPS` (RMS) of the best, at least `idm_windows.speed_floor` (the `desired_quantile` of its speeds
with no leader within `free_gap_m`, and its last speed) and at most `DESIRED_CAP_MPS`. The fit error
(`IdmCalibration.errors`) is reported on the train and validation windows (the test split is not read) for the fitted
parameters and for SUMO's defaults, each with the desired speeds that fit each driver best. In a seat
(`lead_in_desired_speed`) only the seated driver's lead-in is read, its rows before the seat's instant, so nothing
after the seat's start is used; and the desired speed is never below the train drivers' median (`IdmCalibration.
desired_mps`), for a lead-in behind a leader or still speeding up shows too little of it.

The calibration is a pure function of the scene's tracks, split and settings (no file is written): computed where it
is used, in seconds, and recorded with what it drove (evaluate-scene's provenance).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
import pandas as pd

from sumo_rail.recordings.idm import SUMO_DEFAULTS, IdmParameters, simulate
from sumo_rail.recordings.idm_windows import SceneRows, Windows, follow_windows, scene_rows, speed_floor
from sumo_rail.recordings.scene_observations import SceneRoad, scene_routes

BOUNDS = (IdmParameters(0.3, 0.5, 0.3, 0.5, 1.0), IdmParameters(6.0, 9.0, 4.0, 10.0, 8.0))
"""The range of each fitted parameter: decel at most SUMO's emergencyDecel of a car (9 m/s^2)."""
DESIRED_CAP_MPS = 55.55
"""The highest desired speed read [m/s]: SUMO's top speed of a passenger car (its vType maxSpeed)."""
FIT_ITERATIONS = 200
"""The most Levenberg-Marquardt steps of a fit."""
DESIRED_TOLERANCE_MPS = 0.005
"""A desired speed whose windows' speed error is within this of the best one's (RMS) [m/s] fits as well."""


@dataclass(frozen=True)
class CalibrationSettings:
    """How the IDM is calibrated (module docstring)."""

    horizon_s: float = 2.0
    """Length of a fitted window [s]."""
    sample_s: float = 0.5
    """A window starts every this many seconds of a track [s]."""
    free_gap_m: float = 100.0
    """A driver with no leader within this gap [m] is free: its speed then bounds its desired speed from below."""
    desired_quantile: float = 0.95
    """The quantile of a driver's free speeds below which its desired speed is not read."""
    vehicle_class: str = "passenger"
    """The class of the drivers fitted ("passenger" or "truck")."""
    max_windows: int = 20_000
    """At most this many train windows are fitted (drawn by `seed` when there are more)."""
    span_s: tuple[float, float] | None = None
    """Fit only the windows this span (from, to) [s] after each track's first instant (the seats'), or all."""
    loss_scale_mps: float = 0.1
    """Scale of the Cauchy loss [m/s]: speed errors well beyond it barely count."""
    seed: int = 0


def windows_of(rows: SceneRows, vehicles: set[str], step_s: float, settings: CalibrationSettings) -> Windows:
    """`idm_windows.follow_windows` with the settings' horizon, sampling, free gap and span."""
    return follow_windows(rows, vehicles, settings.horizon_s, settings.sample_s, step_s, settings.free_gap_m,
                          settings.desired_quantile, settings.span_s)


def simulated(parameters: IdmParameters, windows: Windows, desired_mps: np.ndarray, step_s: float) -> np.ndarray:
    """The drivers' speeds after each step of each window under `parameters` and the drivers' desired speeds
    `desired_mps` (one per driver), (N, H) [m/s]."""
    return simulate(parameters, windows.speed_mps, desired_mps[windows.driver], windows.gap_m,
                    windows.leader_travel_m, windows.leader_speed_mps, step_s)


def _cauchy(residuals: np.ndarray, scale_mps: float) -> np.ndarray:
    """The Cauchy loss of speed differences [m/s] (least_squares' rho at f_scale `scale_mps`)."""
    return scale_mps**2 * np.log1p((residuals / scale_mps) ** 2)


def fit(windows: Windows, step_s: float, settings: CalibrationSettings) -> tuple[IdmParameters, np.ndarray]:
    """The IDM parameters within `BOUNDS` and the drivers' desired speeds (within [floor, `DESIRED_CAP_MPS`]) that
    fit `windows` best: Levenberg-Marquardt on the Cauchy loss (reweighted least squares), both at once (the desired
    speeds and tau trade off: fitted in turns they converge slowly), from SUMO's defaults and the desired speeds read
    under them. Each step's Jacobian takes six simulations (forward differences: one per parameter, one for every
    driver's desired speed at once, as a window depends on its own driver's only); the desired speeds are eliminated
    from the normal equations (their block is diagonal)."""
    if not len(windows):
        raise ValueError("no window to fit the IDM on: no driver of the split keeps its lane and leader for "
                         f"{settings.horizon_s:g} s")
    low, high = BOUNDS[0].as_array(), BOUNDS[1].as_array()
    floor = np.minimum(windows.floor_mps, DESIRED_CAP_MPS)
    drivers, steps = len(windows.drivers), windows.recorded_mps.shape[1]
    owner = np.repeat(windows.driver, steps)
    scale = settings.loss_scale_mps

    def residuals(values: np.ndarray, desired: np.ndarray) -> np.ndarray:
        return (simulated(IdmParameters.from_array(values), windows, desired, step_s) - windows.recorded_mps).ravel()

    values, desired = SUMO_DEFAULTS.as_array(), read_desired_speeds(SUMO_DEFAULTS, windows, step_s, settings, 0.0)
    error = residuals(values, desired)
    cost, damping = _cauchy(error, scale).sum(), 1e-3
    for _ in range(FIT_ITERATIONS):
        weight = 1.0 / (1.0 + (error / scale) ** 2)
        shifts = 1e-4 * (high - low)
        jacobian = np.stack([(residuals(values + shift * np.eye(5)[j], desired) - error) / shift
                             for j, shift in enumerate(shifts)], axis=1)
        own = (residuals(values, desired + 1e-3) - error) / 1e-3  # each residual's derivative in its driver's v0
        weighted = jacobian * weight[:, None]
        a_block = jacobian.T @ weighted
        b_block = np.stack([np.bincount(owner, weighted[:, j] * own, minlength=drivers) for j in range(5)])
        c_diag = np.bincount(owner, weight * own * own, minlength=drivers) + 1e-9
        gradient_p, gradient_v = weighted.T @ error, np.bincount(owner, weight * own * error, minlength=drivers)
        while True:
            c_damped = c_diag * (1.0 + damping)
            schur = a_block + damping * np.diag(np.diag(a_block)) - (b_block / c_damped) @ b_block.T
            rhs = -gradient_p + b_block @ (gradient_v / c_damped)
            try:
                step_p = np.linalg.solve(schur, rhs)
            except np.linalg.LinAlgError:  # a parameter no window moves (no leader: tau, minGap, decel) stays put
                step_p = np.linalg.lstsq(schur, rhs)[0]
            step_v = (-gradient_v - b_block.T @ step_p) / c_damped
            trial_values = np.clip(values + step_p, low, high)
            trial_desired = np.clip(desired + step_v, floor, DESIRED_CAP_MPS)
            trial_error = residuals(trial_values, trial_desired)
            trial_cost = _cauchy(trial_error, scale).sum()
            if trial_cost < cost or damping > 1e8:
                break
            damping *= 10.0
        if trial_cost >= cost:
            break
        improvement = (cost - trial_cost) / cost
        values, desired, error, cost, damping = trial_values, trial_desired, trial_error, trial_cost, damping / 3.0
        if improvement < 1e-6:
            break
    return IdmParameters.from_array(values), desired


def read_desired_speeds(parameters: IdmParameters, windows: Windows, step_s: float, settings: CalibrationSettings,
                        tolerance_mps: float = DESIRED_TOLERANCE_MPS) -> np.ndarray:
    """Each driver's desired speed [m/s] under `parameters`: the lowest of those that fit its windows within
    `tolerance_mps` (RMS) of the best; on a grid of 1 m/s from its floor, then of 0.1 m/s around the one chosen."""
    floor = np.minimum(windows.floor_mps, DESIRED_CAP_MPS)
    if not len(windows):
        return floor
    steps = np.bincount(windows.driver, minlength=len(floor)) * windows.recorded_mps.shape[1]
    candidates = floor[:, None] + np.arange(0.0, DESIRED_CAP_MPS - floor.min() + 1.0, 1.0)
    for fine in (False, True):
        candidates = np.minimum(candidates, DESIRED_CAP_MPS)
        cost = np.empty(candidates.shape)
        for k in range(candidates.shape[1]):
            errors = simulated(parameters, windows, candidates[:, k], step_s) - windows.recorded_mps
            cost[:, k] = np.bincount(windows.driver, _cauchy(errors, settings.loss_scale_mps).sum(axis=1),
                                     minlength=len(floor))
        fits = cost <= cost.min(axis=1, keepdims=True) + steps[:, None] * tolerance_mps**2
        chosen = candidates[np.arange(len(floor)), np.where(fits, candidates, np.inf).argmin(axis=1)]
        if fine:
            return chosen
        candidates = np.maximum(floor[:, None], chosen[:, None] + np.arange(-1.0, 1.05, 0.1))
    raise AssertionError("unreachable")


@dataclass(frozen=True)
class FitError:
    """How far IDM drives from the recorded drivers over the windows of a split."""

    windows: int
    speed_rmse_mps: float
    """Root mean square of the speed differences at every step [m/s]."""
    speed_median_mps: float
    """Median of the windows' largest speed difference [m/s] (robust to the windows IDM cannot explain)."""
    position_rmse_m: float
    """Root mean square of the distance differences at the windows' ends [m]."""


def fit_error(parameters: IdmParameters, windows: Windows, step_s: float, settings: CalibrationSettings) -> FitError:
    """`parameters`' error on `windows`, each driver's desired speed the one that fits its windows best under them
    (NaN without windows)."""
    if not len(windows):
        return FitError(0, np.nan, np.nan, np.nan)
    desired = read_desired_speeds(parameters, windows, step_s, settings, tolerance_mps=0.0)
    speeds = simulated(parameters, windows, desired, step_s)
    errors = speeds - windows.recorded_mps
    travel = speeds.sum(axis=1) * step_s
    return FitError(len(windows), float(np.sqrt(np.mean(errors**2))), float(np.median(np.abs(errors).max(axis=1))),
                    float(np.sqrt(np.mean((travel - windows.recorded_travel_m) ** 2))))


@dataclass(frozen=True)
class IdmCalibration:
    """A scene's calibrated IDM and its fit: `errors[split][model]` for the train and validation splits, the models
    "calibrated" and "sumo_defaults"."""

    parameters: IdmParameters
    settings: CalibrationSettings
    step_s: float
    drivers: int
    """Train drivers fitted."""
    desired_mps: float
    """The train drivers' median desired speed (fitted with the parameters) [m/s]."""
    errors: dict[str, dict[str, FitError]] = field(default_factory=dict)

    def as_dict(self) -> dict[str, object]:
        """The calibration as plain data (JSON, provenance)."""
        return {"parameters": asdict(self.parameters), "settings": asdict(self.settings), "step_s": self.step_s,
                "drivers": self.drivers, "desired_mps": self.desired_mps,
                "errors": {split: {model: asdict(error) for model, error in models.items()}
                           for split, models in self.errors.items()}}

    def describe(self) -> str:
        """The parameters and the fit error, in a few lines."""
        p = self.parameters
        lines = [f"IDM calibrated on {self.drivers} train drivers: accel {p.accel_mps2:.2f} m/s^2, decel "
                 f"{p.decel_mps2:.2f} m/s^2, tau {p.tau_s:.2f} s, minGap {p.min_gap_m:.2f} m, delta {p.delta:.2f}; "
                 f"their median desired speed {self.desired_mps:.2f} m/s"]
        for split, models in self.errors.items():
            lines.append(f"  {split}, {models['calibrated'].windows} windows of {self.settings.horizon_s:g} s, "
                         "speed RMSE / median largest speed error / position RMSE at the end: " + "; ".join(
                             f"{model} {error.speed_rmse_mps:.3f} / {error.speed_median_mps:.3f} m/s / "
                             f"{error.position_rmse_m:.3f} m" for model, error in models.items()))
        return "\n".join(lines)


def calibrate(tracks: pd.DataFrame, split: pd.DataFrame, road: SceneRoad, step_s: float,
              settings: CalibrationSettings = CalibrationSettings()) -> IdmCalibration:
    """The IDM fitted on the train drivers of `settings.vehicle_class` in `tracks` (a scene's `TRACK_COLUMNS` on the
    network of `road`; `split`: vehicle_id -> split), with its error on the train and validation windows beside SUMO's
    defaults'."""
    rows = scene_rows(tracks, road, step_s)
    kind = tracks.drop_duplicates("vehicle_id").set_index("vehicle_id")["vehicle_class"]
    members = {name: set(split.loc[split["split"] == name, "vehicle_id"].astype(str))
               & set(kind.index[kind == settings.vehicle_class].astype(str)) for name in ("train", "validation")}
    windows = {name: windows_of(rows, ids, step_s, settings) for name, ids in members.items()}
    rng = np.random.default_rng(settings.seed)
    for name, found in windows.items():
        if len(found) > settings.max_windows:
            windows[name] = found.subset(np.sort(rng.choice(len(found), settings.max_windows, replace=False)))
    parameters, desired = fit(windows["train"], step_s, settings)
    errors = {name: {"calibrated": fit_error(parameters, found, step_s, settings),
                     "sumo_defaults": fit_error(SUMO_DEFAULTS, found, step_s, settings)}
              for name, found in windows.items()}
    return IdmCalibration(parameters, settings, step_s, len(windows["train"].drivers), float(np.median(desired)),
                          errors)


def lead_in_desired_speed(tracks: pd.DataFrame, road: SceneRoad, vehicle: str, start_s: float,
                          parameters: IdmParameters, step_s: float,
                          settings: CalibrationSettings = CalibrationSettings(), typical_mps: float = 0.0) -> float:
    """The desired speed [m/s] of `vehicle` under `parameters`, read from its lead-in: the scene's rows (on the network
    of `road`) before `start_s` [s] (its first row alone, when the seat is taken where its track begins), its leaders
    found along its recorded route (the seat's), its floor when the lead-in holds no window; never below `typical_mps`
    (the train drivers' median, where a lead-in shows too little)."""
    own = tracks[tracks["vehicle_id"] == vehicle]
    if own.empty:
        raise ValueError(f"the scene has no vehicle {vehicle!r}")
    begin_s = float(own["time_s"].min())
    times = tracks["time_s"]
    lead_in = tracks[(times >= begin_s) & (times < max(start_s - 1e-9, begin_s + step_s / 2))]
    rows = scene_rows(lead_in, road, step_s, scene_routes(lead_in) | scene_routes(own))
    windows = windows_of(rows, {vehicle}, step_s, settings)
    if len(windows):
        read = float(read_desired_speeds(parameters, windows, step_s, settings)[0])
    else:
        mine = rows.vehicle == vehicle
        read = min(speed_floor(rows.speed_mps[mine], rows.gap_m[mine], settings.free_gap_m,
                               settings.desired_quantile), DESIRED_CAP_MPS)
    return max(read, typical_mps)
