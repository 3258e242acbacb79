"""Who drives in a recorded scene besides the recording: the other vehicles of the reactive mode and SUMO's IDM in a
seat, each from what the recording says (docs/replay.md).

- The reactive mode (`reactive_types`): each vehicle is driven by its recorded SUMO vType where the recording names
  one and came with its definition (`SceneMeta.vehicle_types` and `vtypes`: an FCD recording's `type` with the route
  or additional file given to `import-recording --vtypes`, SUMO's drivers' own types); every other vehicle by SUMO's
  IDM calibrated on the scene's train split (`idm_calibration.calibrate` on `REACTIVE_CALIBRATION`'s windows drawn
  from every train track; LC2013 lane changing; the trucks of SUMO's class truck), or SUMO's default Krauss where
  the split has nothing to fit. A vehicle recorded as SUMO's default type (FCD of a vehicle without a type) drives
  it: no file defines it, SUMO does. Its desired speed is the fastest its track records (`sim.replay`), whatever its
  type. A recorded type named as one the simulation defines itself (`BUILT_IN_TYPES`) drives under another name
  (`sumo_type_ids`), said in the note.
- The seat (`seat_calibration`, `evaluate-scene --policy sumo-idm-calibrated`): SUMO's IDM with the parameters fitted
  on the seats of the train drivers of the seat's class (the span `lead_s` to `lead_s` + `horizon_s` into each track)
  and the desired speed read from the seated driver's lead-in (`idm_calibration.lead_in_desired_speed`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from sumo_rail.recordings.idm import IdmParameters
from sumo_rail.recordings.idm_calibration import CalibrationSettings, IdmCalibration, calibrate
from sumo_rail.recordings.scene import Scene
from sumo_rail.sim.controllers import SUMO_DRIVER_TYPE
from sumo_rail.sim.replay import DEFAULT_TYPE, VehicleTypes
from sumo_rail.sim.scenarios import ACCELERATION_EGO_TYPE, EGO_TYPE

REACTIVE_IDM_TYPE = "scene_idm_calibrated"
"""The vType of the reactive vehicles the calibrated IDM drives."""
REACTIVE_IDM_TRUCK_TYPE = "scene_idm_calibrated_truck"
"""The same of the recording's trucks (SUMO's class truck)."""
SEAT_IDM_TYPE = "seat_idm_calibrated"
"""The vType of the calibrated IDM in a seat."""
BUILT_IN_TYPES = (EGO_TYPE, ACCELERATION_EGO_TYPE, SUMO_DRIVER_TYPE, DEFAULT_TYPE, REACTIVE_IDM_TYPE,
                  REACTIVE_IDM_TRUCK_TYPE, SEAT_IDM_TYPE)
"""The vType ids a scene's simulation defines itself (the egos', SUMO's driver in a seat, SUMO's default one that drives
every vehicle without a type, the calibrated IDM's): a recorded type of one of these names drives under another
(`sumo_type_ids`), so it neither clashes with it in SUMO nor takes over its vehicles."""
RENAMED_SUFFIX = "_recorded"
REACTIVE_CALIBRATION = CalibrationSettings(max_windows=2000)
"""How the reactive vehicles' IDM is calibrated: 2,000 train windows drawn from all (the default 20,000 took 190 s on
a 600 s scene of SUMO's drivers, 2,000 about 10 s)."""


def idm_type(parameters: IdmParameters) -> dict[str, str]:
    """The vType attributes of SUMO's IDM with `parameters` and LC2013 lane changing."""
    return {**parameters.vtype_attributes(), "laneChangeModel": "LC2013"}


@dataclass(frozen=True)
class ReactiveTypes:
    """Who drives the reactive vehicles of a scene: `types` (for `sim.replay`), how many vehicles drive their
    recorded type and how many the calibrated IDM (`calibration`, None when none was needed or possible), and
    `note`: why a vehicle does not drive its recorded type, if any."""

    types: VehicleTypes
    recorded: int
    calibrated: int
    calibration: IdmCalibration | None
    note: str

    def describe(self) -> str:
        """Who drives, in a sentence or two."""
        others = ("SUMO's IDM calibrated on the train split" if self.calibration is not None
                  else "SUMO's default Krauss")
        said = [f"reactive vehicles: {self.recorded} driven by their recorded vType"
                + (f", {self.calibrated} by {others}" if self.calibrated else "")]
        if self.calibration is not None:
            said.append(self.calibration.describe())
        return "\n".join(said + ([self.note] if self.note else []))

    def as_dict(self) -> dict[str, Any]:
        """The choice as plain data (provenance)."""
        return {"recorded_vtype": self.recorded, "calibrated_idm" if self.calibration else "sumo_default":
                self.calibrated, "vtypes": {key: dict(value) for key, value in self.types.definitions.items()},
                "calibration": self.calibration.as_dict() if self.calibration else None, "note": self.note}


def sumo_type_ids(type_ids: set[str]) -> dict[str, str]:
    """Each recorded vType id of `type_ids` -> the id SUMO knows it by: itself, or for one of `BUILT_IN_TYPES` that id
    and `RENAMED_SUFFIX` (and a number, while that is taken too)."""
    taken = set(type_ids) | set(BUILT_IN_TYPES)
    renamed = {}
    for type_id in sorted(type_ids & set(BUILT_IN_TYPES)):
        name, number = f"{type_id}{RENAMED_SUFFIX}", 1
        while name in taken:
            name, number = f"{type_id}{RENAMED_SUFFIX}{number}", number + 1
        renamed[type_id] = name
        taken.add(name)
    return {type_id: renamed.get(type_id, type_id) for type_id in type_ids}


def reactive_types(scene: Scene, step_s: float) -> ReactiveTypes:
    """The reactive mode's drivers of `scene` (module docstring), for SUMO's step `step_s` [s]."""
    meta = scene.meta
    vehicles = scene.split["vehicle_id"].astype(str).tolist()
    recorded = {vehicle: meta.vehicle_types[vehicle] for vehicle in vehicles
                if meta.vehicle_types.get(vehicle) in meta.vtypes}
    sumo_default = {vehicle for vehicle in vehicles  # recorded as SUMO's own type, which drives them here too
                    if meta.vehicle_types.get(vehicle) == DEFAULT_TYPE and vehicle not in recorded}
    missing = sorted({meta.vehicle_types[vehicle] for vehicle in vehicles
                      if vehicle in meta.vehicle_types and vehicle not in recorded.keys() | sumo_default})
    note = (f"the recording names vTypes without their definitions ({', '.join(missing[:5])}"
            f"{', ...' if len(missing) > 5 else ''}): give its route or additional file to import-recording "
            f"--vtypes" if missing else "")
    sumo_ids = sumo_type_ids(set(recorded.values()))
    renamed = [f"{type_id} as {sumo_id}" for type_id, sumo_id in sorted(sumo_ids.items()) if type_id != sumo_id]
    if renamed:
        note = "; ".join(filter(None, [note, f"recorded vTypes named as this project's own drive under another name in "
                                             f"SUMO: {', '.join(renamed)}"]))
    definitions = {sumo_ids[type_id]: meta.vtypes[type_id] for type_id in sorted(sumo_ids)}
    recorded = {vehicle: sumo_ids[type_id] for vehicle, type_id in recorded.items()}
    others = len(vehicles) - len(recorded) - len(sumo_default)
    calibration = None
    if others:
        try:
            calibration = calibrate(scene.tracks, scene.split, scene.road, step_s, REACTIVE_CALIBRATION)
        except ValueError as error:
            note = "; ".join(filter(None, [note, f"no IDM could be calibrated on the train split ({error})"]))
    if calibration is not None:
        trucks = set(scene.tracks.loc[scene.tracks["vehicle_class"] == "truck", "vehicle_id"].astype(str))
        calibrated = {vehicle: REACTIVE_IDM_TRUCK_TYPE if vehicle in trucks else REACTIVE_IDM_TYPE
                      for vehicle in vehicles if vehicle not in recorded and vehicle not in sumo_default}
        definitions[REACTIVE_IDM_TYPE] = idm_type(calibration.parameters)
        if REACTIVE_IDM_TRUCK_TYPE in calibrated.values():
            definitions[REACTIVE_IDM_TRUCK_TYPE] = {**definitions[REACTIVE_IDM_TYPE], "vClass": "truck"}
        recorded |= calibrated
    return ReactiveTypes(VehicleTypes(definitions, recorded), len(vehicles) - others, others, calibration, note)


def seat_calibration(scene: Scene, step_s: float, lead_s: float, horizon_s: float,
                     vehicle_class: str = "passenger") -> IdmCalibration:
    """SUMO's IDM calibrated on the seats of `scene`'s train drivers of `vehicle_class` (the span `lead_s` to `lead_s`
    + `horizon_s` [s] into each track, where evaluate-scene seats the held-out ones); ValueError in one sentence naming
    the scene when its train split has nothing to fit."""
    settings = CalibrationSettings(span_s=(lead_s, lead_s + horizon_s), vehicle_class=vehicle_class)
    try:
        return calibrate(scene.tracks, scene.split, scene.road, step_s, settings)
    except ValueError as error:
        drivers = "" if vehicle_class == "passenger" else f" ({vehicle_class} drivers)"
        raise ValueError(f"cannot calibrate SUMO's IDM on the train split of the scene {scene.folder}{drivers}: "
                         f"{error}") from error
