"""The committed tables under docs/results say what the committed data say: each one the script that made it
regenerates, line by line, from the committed data; the others are listed with the reason they cannot be, and no
committed table escapes both lists (so prose quoting a table quotes something the data hold)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
R = "docs/results"
BENCH_TESTS = [f"{R}/imitation_table/data/test_s{seed}.parquet" for seed in range(5)]
DESIGNS = ["lidar24", "lidar72", "lidar24_lanes", "lidar24_sensor_expert", "lidar24_lanes_sensor_expert"]

# table -> the command that made it, on the committed data. "@FOLDER": a scratch folder of links to FOLDER's files (the
# figures a script writes beside its inputs land there, not in docs/results); "figure:PATH": a scratch figure, named
# PATH in the output; "out:NAME": the table is the file NAME the command writes in its scratch folder, not its stdout.
REGENERATED: dict[str, list[str]] = {
    "imitation_table/table.md": ["experiments/benchmark_table.py", f"{R}/imitation_table/data"],
    "realizable/table.md": ["experiments/benchmark_table.py", f"{R}/realizable/data"],
    "realizable_ppo/table.md": ["experiments/benchmark_table.py", f"{R}/realizable_ppo/data"],
    "generalisation/table.md": ["experiments/generalisation_table.py", f"{R}/generalisation/data",
                                f"figure:{R}/generalisation/generalisation.png"],
    "dart/table.md": ["experiments/dart_table.py", f"{R}/imitation_table/data", f"{R}/dart/data", f"{R}/safety/data",
                      f"{R}/safety/gail"],
    "safety_realizable/table.md": ["experiments/dart_table.py", f"{R}/realizable_ppo/data", "-",
                                   f"{R}/safety_realizable/data"],
    "shared_road/table.md": ["experiments/shared_road_table.py", "8", f"{R}/shared_road/test_k8.parquet",
                             f"{R}/shared_road/test_k8_gail.parquet", *BENCH_TESTS],
    "respawning/table.md": ["experiments/shared_road_table.py", "8", f"{R}/respawning/test_k8.parquet", *BENCH_TESTS],
    "demonstrations_sweep/table.md": ["experiments/demonstrations_plot.py", f"@{R}/demonstrations_sweep",
                                      "5", "10", "20", "40", "100", "200"],
    "demonstrations_sweep/train_defaults/table.md": ["experiments/demonstrations_plot.py",
                                                     f"@{R}/demonstrations_sweep/train_defaults", "5", "10"],
    "directions_sweep/table.md": ["experiments/directions_plot.py", f"@{R}/directions_sweep"],
    "rail_remedies/table.md": ["experiments/remedies_table.py", f"{R}/rail_remedies/validation_control.parquet",
                               f"{R}/rail_remedies/validation_flip20_ep4.parquet"],
    "recovery/table.md": ["experiments/recovery_table.py", f"{R}/recovery/data", f"figure:{R}/recovery/recovery.png"],
    "step_signal/table.md": ["experiments/step_signal_table.py", f"{R}/step_signal",
                             f"figure:{R}/step_signal/step_signal.png"],
    "step_signal/agreement_episodes.md": ["experiments/agreement_episodes.py", "normal", *BENCH_TESTS],
    "observation_study/table.md": ["experiments/observation_table.py", f"@{R}/observation_study", *DESIGNS],
    "style_fidelity/table.md": ["experiments/style_table.py", f"{R}/style_fidelity/test.parquet"],
    "bc_class_balance/table.md": ["experiments/bc_class_balance_table.py", f"{R}/bc_class_balance/validation.parquet"],
    "human_likeness/table.md": ["experiments/human_likeness_open_loop.py", "table",
                                f"{R}/human_likeness/open_loop.parquet"],
    "human_likeness/closed_loop.md": ["experiments/human_likeness_closed_loop.py",
                                      f"{R}/human_likeness/closed_loop.parquet"],
    "human_likeness_acceleration/test.md": ["experiments/human_likeness_closed_loop.py", "--study", "acceleration",
                                            f"{R}/human_likeness_acceleration/test.parquet"],
    "human_likeness_acceleration/open_loop.md": ["experiments/acceleration_open_loop.py", "table",
                                                 f"{R}/human_likeness_acceleration/open_loop.parquet"],
    "log_teacher/validation.md": ["experiments/log_teacher_horizon.py", f"{R}/log_teacher/validation.parquet"],
    "log_study/log_test.md": ["experiments/human_likeness_closed_loop.py", "--study", "log", "--intervals",
                              "hierarchical", f"{R}/log_study/log_test.parquet"],
    "log_study/road2_test.md": ["experiments/human_likeness_closed_loop.py", "--study", "log", "--intervals",
                                "hierarchical", f"{R}/log_study/road2_test.parquet"],
    "human_likeness_acceleration/open_loop_decoding.md": ["experiments/acceleration_open_loop.py", "table",
                                                          f"{R}/human_likeness_acceleration/open_loop_decoding.parquet"],
    "ppo_expert/lane_change_context.md": ["experiments/lane_change_context.py",
                                          f"{R}/ppo_expert/test_ppo_expert.decisions.parquet"],
    "ars_reference/table.md": ["experiments/ars_reference.py", "--seeds", "0", "1", "2", "3", "4",
                               "--out", f"@{R}/ars_reference", "out:table.md"],
    "ars_reference/swimmer_small_step/table.md": [
        "experiments/ars_reference.py", "--task", "Swimmer-v5", "--implementation", "sumo-rail", "--seeds", "0", "1",
        "2", "3", "4", "--out", f"@{R}/ars_reference/swimmer_small_step", "out:table.md"],
    "fidelity_demo/report/report.md": [
        "-m", "sumo_rail_cli", "report", f"{R}/fidelity_demo/demo_run", f"{R}/fidelity_demo/evaluation.parquet",
        "--out", f"@{R}/fidelity_demo/report", "out:report.md"],
    "imitation_table/report/report.md": [
        "-m", "sumo_rail_cli", "report", *(f"{R}/imitation_table/data/{run}_s0" for run in ("rail_mlp", "rail_linear",
                                                                                           "gail")),
        BENCH_TESTS[0], "--out", f"@{R}/imitation_table/report", "out:report.md"],
}

NOT_REGENERABLE: dict[str, str] = {
    "gail_choices/validation.md": "its evaluation (results/gail_choices/validation.parquet) is not committed, only "
                                  "evaluate's printout validation.txt",
    "rail_ablations/test.md": "its evaluations and runs (results/ablations_lanes) are not committed",
    "rail_ablations/validation.md": "its evaluations and runs (results/ablations_lanes) are not committed",
    "step_size_effect/table.md": "its runs and demonstrations (results/step_size_effect) are not committed",
    "ppo_expert/actions.md": "its demonstrations (results/imitation_table/demos.parquet, 33,229 states) are not "
                             "committed",
    "observation_study/final.md": "its per-episode evaluations (DESIGN/validation.parquet) are not committed, only "
                                  "evaluate's printouts DESIGN/validation.txt",
    "action_rule/expert.md": "a simulation, not a table of committed data: experiments/action_rule_validation.py "
                             "drives the expert in SUMO for about 4 min",
    "acceleration_reading/table.md": "a simulation, not a table of committed data: "
                                     "experiments/acceleration_reading_validation.py drives the expert, a random "
                                     "driver and SUMO's drivers in SUMO for about 13 min on a busy 2-core machine",
    "road_capacity/table.md": "a simulation, not a table of committed data: experiments/road_capacity.py runs SUMO "
                              "for about 21 min",
    "road_capacity/ramp_flows.md": "a simulation, not a table of committed data (experiments/road_capacity.py "
                                   "--ramp-flows runs SUMO), whose first line records its wall time",
    "human_likeness_acceleration/validation.md": "its evaluations (results/human_likeness/acceleration_validation_h0 "
                                                 "and _h3, 3.7 MB with their tracks) are not committed; the grid spec "
                                                 "human_likeness_acceleration.toml makes them again",
    "human_likeness_acceleration/validation_seat_showed_0.md": "its evaluations are not committed and no longer made: "
                                                               "the seats then showed 0 m/s^2 as the last command "
                                                               "before the first decision (before commit 1ae2b34)",
    "log_study/decoding_validation.md": "its evaluations (results/human_likeness/decoding_validation*, 3.8 MB with "
                                        "their tracks) are not committed; the grid spec log_decoding_validation.toml "
                                        "makes them again",
    "log_study/log_validation.md": "its evaluations (results/human_likeness/log_validation, 2.7 MB with their tracks) "
                                   "are not committed; the grid spec human_likeness_log.toml makes them again",
    "rail_seats/validation.md": "its evaluations (results/human_likeness/rail_seats_validation, 2.4 MB with their "
                                "tracks) are not committed; the grid spec human_likeness_rail_seats.toml makes them "
                                "again",
    "rail_seats/test.md": "its table takes minutes to make from the committed episodes (test.parquet beside "
                          "log_study/log_test.parquet) and this suite is at its time limit (docs/results.md, \"RAIL in "
                          "recorded seats against BC\", has the command)",
    "log_temperature/validation.md": "its evaluations (results/human_likeness/temperature_validation_*, 4 MB with "
                                     "their tracks, read beside decoding_validation's) are not committed; the grid "
                                     "spec human_likeness_log_temperature.toml makes them again",
    "log_temperature/test.md": "its table takes minutes to make from the committed episodes (test.parquet beside "
                               "log_study/log_test.parquet) and this suite is at its time limit (docs/results.md, "
                               "\"The driver trained against the log, sampled at a temperature\", has the command)",
    "log_temperature/road2_test.md": "as log_temperature/test.md (road2_test.parquet beside "
                                     "log_study/road2_test.parquet)",
    "gail_seats/validation.md": "its evaluations (results/human_likeness/gail_seats_validation, 2.4 MB with their "
                                "tracks) are not committed; the grid spec human_likeness_gail_seats.toml makes them "
                                "again",
    "gail_seats/test.md": "its table takes minutes to make from the committed episodes (test.parquet beside "
                          "log_study/log_test.parquet) and this suite is at its time limit (docs/results.md, \"GAIL in "
                          "recorded seats against BC\", has the command)",
    "log_history/validation.md": "its evaluations (results/human_likeness/history_validation, 2.5 MB with their "
                                 "tracks, read beside log_validation's) are not committed; the grid spec "
                                 "human_likeness_log_history.toml makes them again",
    "log_history/test.md": "its table takes minutes to make from the committed episodes (test.parquet beside "
                           "log_study/log_test.parquet) and this suite is at its time limit (docs/results.md, \"What "
                           "the seated driver's past adds\", has the command)",
    "fidelity_demo/table.txt": "evaluate's printout of the simulated evaluation, not a table script's output",
    "generalisation/previous_5b09e52/table.md": "an earlier run's table as published then; its evaluations are not "
                                                "committed",
    "generalisation/previous_expert/table.md": "an earlier run's table as published then, by an earlier "
                                               "generalisation_table.py; its evaluations are not committed (the "
                                               "expert's 50 episodes the folder held were not the 250 it was made "
                                               "with; issue 45 removed them)",
    "generalisation/previous_learners/table.md": "an earlier run's table as published then; its evaluations are not "
                                                 "committed (the expert's 50 episodes the folder held were not the "
                                                 "250 it was made with; issue 45 removed them)",
}


def committed_tables() -> set[str]:
    """Every committed table: the Markdown files under docs/results (but a folder's README.md, its prose) and the files
    named table*.txt."""
    return {path.relative_to(RESULTS).as_posix() for path in RESULTS.rglob("*")
            if path.is_file() and path.name != "README.md"
            and (path.suffix == ".md" or (path.name.startswith("table") and path.suffix == ".txt"))}


def regenerate(table: str, scratch: Path) -> str:
    """Run the table's command on the committed data; the table it printed (or wrote) with scratch paths renamed."""
    scratch.mkdir(parents=True)
    arguments, renames, written, folder = [], {}, None, scratch
    for argument in REGENERATED[table]:
        if argument.startswith("@"):
            folder = scratch / f"folder{len(arguments)}"
            folder.mkdir()
            for entry in (ROOT / argument[1:]).iterdir():
                if entry.suffix not in {".png", ".md"}:  # the script's own outputs are written anew
                    (folder / entry.name).symlink_to(entry)
            arguments.append(str(folder))
        elif argument.startswith("figure:"):
            figure = scratch / Path(argument).name
            renames[str(figure)] = argument.removeprefix("figure:")
            arguments.append(str(figure))
        elif argument.startswith("out:"):
            written = argument.removeprefix("out:")
        else:
            arguments.append(argument)
    environment = {**os.environ, "MPLBACKEND": "Agg", "OMP_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, *arguments], cwd=ROOT, env=environment, capture_output=True, text=True,
                          check=False)
    assert done.returncode == 0, f"{table}: {' '.join(arguments)} failed:\n{done.stderr[-3000:]}"
    text = done.stdout if written is None else (folder / written).read_text()
    for scratch_path, committed in renames.items():
        text = text.replace(scratch_path, committed)
    return text


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """Every regenerable table, made two at a time (the slowest, the log study's bootstraps, first)."""
    root = tmp_path_factory.mktemp("tables")
    order = sorted(REGENERATED, key=lambda table: not table.startswith("log_study/"))
    with ThreadPoolExecutor(max_workers=2) as pool:
        futures = {table: pool.submit(regenerate, table, root / f"t{index}") for index, table in enumerate(order)}
    return {table: future.result() for table, future in futures.items()}


def test_every_committed_table_is_regenerated_or_listed_with_its_reason():
    listed = set(REGENERATED) | set(NOT_REGENERABLE)
    assert not set(REGENERATED) & set(NOT_REGENERABLE)
    assert committed_tables() - listed == set(), "a committed table neither regenerated nor listed with a reason"
    assert listed - committed_tables() == set(), "a listed table is not committed"
    assert all(reason.strip() for reason in NOT_REGENERABLE.values())


@pytest.mark.parametrize("table", sorted(REGENERATED))
def test_a_committed_table_is_what_its_script_makes_of_the_committed_data(table: str, regenerated: dict[str, str]):
    committed = (RESULTS / table).read_text().splitlines()
    produced = regenerated[table].splitlines()
    for number, (want, got) in enumerate(zip(committed, produced, strict=False), start=1):
        assert got == want, f"{table} line {number} differs:\ncommitted:   {want}\nregenerated: {got}"
    assert len(produced) == len(committed), f"{table}: {len(committed)} lines committed, {len(produced)} regenerated"


def test_every_file_the_docs_link_to_is_committed():
    documents = [ROOT / "README.md", *(ROOT / "docs").glob("*.md")]
    missing = [f"{document.name}: {target}" for document in documents
               for target in re.findall(r"\]\(([^)#\s]+)\)", document.read_text())
               if not target.startswith(("http://", "https://")) and not (document.parent / target).exists()]
    assert missing == []
