"""How much traffic each generated road carries: SUMO alone (no ego) on each road at rising flows, with the project's
own network, traffic and options (`sumo_rail.sim.simulation.sumo_options`), one run a flow and traffic seed.
A road carries a flow when, over the measured time (after a warm-up), its vehicles leave as fast as they arrive
(delivered >= 95% of the demand, mean of the seeds: 600 s of Poisson arrivals spread a few percent), no more than
20 vehicles wait to be inserted at the end (every seed), and the mean speed of the vehicles on the road stays at
least 75% of its value at the lowest flow. The flows are given a lane of the road's narrowest part (the work
zone's lanes on lane_drop, the five lanes past the merge, the main road's lanes on exit, whose off-ramp takes
exit_share of the flow), so the limits of `sumo_rail.config` can be read off the table; flows beyond them are built
here without the checks that refuse them to users.
Usage: `python experiments/road_capacity.py --out docs/results/road_capacity/table.md [--seeds 3]`; with
`--ramp-flows R [R ...]`, instead the on-ramp (kind merge, the main road's default flow) at each ramp flow R [veh/h].
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from xml.etree import ElementTree

from sumo_rail.config import ScenarioConfig
from sumo_rail.datasets import written_atomically
from sumo_rail.sim import network
from sumo_rail.sim.simulation import sumo_options

ROADS = (("straight", 0.2), ("merge", 0.2), ("lane_drop", 0.2), ("exit", 0.2), ("exit", 0.1))
"""(scenario.kind, scenario.exit_share); merge_from_ramp has the merge's road and traffic."""
PER_LANE_VEH_PER_H = (1200, 1400, 1600, 1800, 2000, 2200, 2400, 2600, 3000)
WARMUP_S, MEASURED_S = 300, 600


def scenario_at(kind: str, exit_share: float, per_lane_veh_per_h: float) -> ScenarioConfig:
    """The road `kind` with its narrowest part carrying `per_lane_veh_per_h` a lane (settings otherwise default)."""
    defaults = ScenarioConfig(kind=kind)
    if kind == "lane_drop":
        flow = per_lane_veh_per_h * (defaults.lanes - defaults.dropped_lanes)
    elif kind == "merge":
        flow = per_lane_veh_per_h * defaults.lanes - defaults.ramp_flow_veh_per_h
    else:
        flow = per_lane_veh_per_h * defaults.lanes
    return ScenarioConfig(kind=kind, flow_veh_per_h=flow, exit_share=exit_share)


def cases(ramp_flows: list[float] | None) -> list[tuple[str, float, ScenarioConfig]]:
    """(the row's road, its veh/h a lane at the narrowest part, the scenario) of every row, in order."""
    if ramp_flows:
        lanes = ScenarioConfig(kind="merge").lanes
        return [(f"merge (ramp {flow:g} veh/h)", (ScenarioConfig(kind="merge").flow_veh_per_h + flow) / lanes,
                 ScenarioConfig(kind="merge", ramp_flow_veh_per_h=flow)) for flow in ramp_flows]
    return [(f"{kind} (exit_share {exit_share:g})" if kind == "exit" else kind, per_lane,
             scenario_at(kind, exit_share, per_lane)) for kind, exit_share in ROADS for per_lane in PER_LANE_VEH_PER_H]


def run(scenario: ScenarioConfig, seed: int) -> dict[str, float]:
    """SUMO alone for WARMUP_S + MEASURED_S: delivered flow [veh/h], insertion backlog at the end [veh], mean speed
    of the vehicles on the road over the measured time [m/s]."""
    built = network.build(scenario)
    with tempfile.TemporaryDirectory() as folder:
        summary = Path(folder) / "summary.xml"
        subprocess.run([network.sumo_binary("sumo"), *sumo_options(scenario, built), "--seed", str(seed),
                        "--end", str(WARMUP_S + MEASURED_S), "--summary-output", str(summary)],
                       check=True, capture_output=True)
        steps = [step.attrib for step in ElementTree.parse(summary).getroot()]
    measured = [step for step in steps if float(step["time"]) >= WARMUP_S]
    arrived = float(measured[-1]["arrived"]) - float(measured[0]["arrived"])
    return {"delivered": arrived * 3600.0 / MEASURED_S, "backlog": float(measured[-1]["waiting"]),
            "speed": statistics.mean(float(step["meanSpeed"]) for step in measured if float(step["running"]) > 0)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--ramp-flows", type=float, nargs="+", help="the on-ramp at these ramp flows [veh/h] instead")
    args = parser.parse_args()
    started = time.time()
    rows = ["| road | veh/h a lane at the narrowest part | scenario.flow_veh_per_h | exit traffic [veh/h] | "
            "delivered / demand | backlog at the end [veh] | mean speed [m/s] | carried |",
            "|---|---|---|---|---|---|---|---|"]
    free_speeds: dict[str, float] = {}
    for road, per_lane, scenario in cases(args.ramp_flows):
        kind = scenario.kind
        demand = scenario.flow_veh_per_h + (scenario.ramp_flow_veh_per_h if kind == "merge" else 0.0)
        runs = [run(scenario, seed) for seed in range(1, args.seeds + 1)]
        free_speed = free_speeds.setdefault(road.split(" (ramp")[0], statistics.mean(r["speed"] for r in runs))
        delivered, speed = (statistics.mean(r[key] for r in runs) for key in ("delivered", "speed"))
        backlog = max(r["backlog"] for r in runs)
        carried = delivered >= 0.95 * demand and backlog <= 20 and speed >= 0.75 * free_speed
        exit_traffic = f"{scenario.flow_veh_per_h * scenario.exit_share:g}" if kind == "exit" else "-"
        rows.append(f"| {road} | {per_lane:g} | {scenario.flow_veh_per_h:g} | {exit_traffic} | "
                    f"{delivered / demand:.2f} | {backlog:.0f} | {speed:.1f} | "
                    f"{'yes' if carried else '**no**'} |")
        print(rows[-1], flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with written_atomically(args.out) as written:
        written.write_text(f"Command: `python {' '.join(sys.argv)}` ({time.time() - started:.0f} s; SUMO alone, "
                           f"{args.seeds} traffic seeds a flow, {WARMUP_S} s warm-up then {MEASURED_S} s "
                           f"measured)\n\n" + "\n".join(rows) + "\n")


if __name__ == "__main__":
    main()
