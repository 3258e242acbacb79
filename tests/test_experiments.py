import dataclasses
import json
import re
import subprocess
import sys
from pathlib import Path

import click
import numpy as np
import pytest

from sumo_rail.datasets import FORMAT_VERSION
from sumo_rail.drivers.policies import Policy, PolicyShape, save_policy
from sumo_rail.evaluation.statistics import Interval
from sumo_rail.learning.rail.ars import ars_update
from sumo_rail.learning.rail.iteration import RailSettings

EXPERIMENTS = Path(__file__).parent.parent / "experiments"
SCRIPTS = sorted(EXPERIMENTS.glob("*.sh"))
sys.path.insert(0, str(EXPERIMENTS))  # the experiments' Python modules import each other by name
from directions_plot import trend_word  # noqa: E402
from wander import wander  # noqa: E402


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda path: path.name)
def test_experiment_scripts_parse_and_are_executable(script: Path):
    assert subprocess.run(["bash", "-n", str(script)], capture_output=True, text=True).returncode == 0
    assert script.stat().st_mode & 0o111


def test_the_demo_is_the_one_shell_script_and_every_documented_experiment_is_a_spec():
    """Experiments are specs run by experiments/grid.py; docs name each by its spec, and every spec they name exists."""
    assert [path.name for path in SCRIPTS] == ["demo.sh"]
    documents = [EXPERIMENTS.parent / "README.md", *sorted((EXPERIMENTS.parent / "docs").glob("*.md"))]
    named = {name for document in documents for name in re.findall(r"experiments/specs/(\w+)\.toml",
                                                                    document.read_text())}
    assert {"imitation_table", "generalisation", "dart", "bc_class_balance"} <= named
    missing = [name for name in named if name != "NAME" and not (EXPERIMENTS / "specs" / f"{name}.toml").is_file()]
    assert sorted(missing) == []


def _searched_run(folder: Path, signal: float, iterations: int = 60) -> Path:
    """A run folder whose linear policy took `iterations` ARS steps from zeros, with returns r+- = +-signal x
    (delta . g) plus unit noise: signal 0 is a search without signal."""
    rng = np.random.default_rng(0)
    settings, shape = RailSettings(directions=16, step_size=0.02), PolicyShape("linear", 40)
    theta, gradient = np.zeros(shape.parameter_count, np.float32), rng.normal(size=shape.parameter_count)
    for _ in range(iterations):
        deltas = rng.normal(size=(settings.directions, theta.size))
        along = signal * deltas @ gradient / np.linalg.norm(gradient)
        plus, minus = (sign * along + rng.normal(size=settings.directions) for sign in (1, -1))
        theta = ars_update(theta, deltas, plus, minus, settings.kept, settings.step_size).parameters
    folder.mkdir()
    record = {"format_version": FORMAT_VERSION, "settings": {"rail": dataclasses.asdict(settings)}}
    (folder / "run.json").write_text(json.dumps(record))
    save_policy(Policy(shape, theta), folder / "policy_latest.npz", {"iteration": iterations})
    return folder


def test_wander_ratio_tells_a_search_without_signal_from_a_drift(tmp_path: Path):
    noise = wander(_searched_run(tmp_path / "noise", signal=0.0))
    drift = wander(_searched_run(tmp_path / "drift", signal=3.0))
    assert 0.85 < noise.ratio < 1.15  # the weights wandered as far as noise goes
    assert drift.ratio > 2.0  # a consistent direction carries them far beyond it
    assert noise.iterations == 60 and noise.settings.kept == 8


def test_directions_trend_words():
    assert trend_word(Interval(0.05, 0.01, 0.09)) == "rising"
    assert trend_word(Interval(-0.04, -0.07, -0.01)) == "falling"
    assert trend_word(Interval(-0.006, -0.014, 0.002)) == "flattened"
    assert trend_word(Interval(0.01, -0.04, 0.06)) == "undecided"


def test_the_benchmark_table_finds_its_expert_whoever_it_is():
    import pandas as pd
    from benchmark_table import expert_driver

    rule = pd.DataFrame({"policy": ["expert-normal", "bc_mlp_s0/policy_bc", "dagger_s0/policy_latest"]})
    learnt = pd.DataFrame({"policy": ["expert-distilled/policy_latest", "dagger_s0/policy_latest"]})
    assert expert_driver(rule) == "expert-normal"
    assert expert_driver(learnt) == "expert-distilled/policy_latest"
    for drivers in (["bc_mlp_s0/policy_bc"], ["expert-normal", "expert-calm"]):
        with pytest.raises(SystemExit, match="expected one expert"):
            expert_driver(pd.DataFrame({"policy": drivers}))


def test_disagreements_split_by_kind_and_pool_training_seeds():
    import pandas as pd
    from disagreements import disagreement_kinds

    keep, faster, slower, left, right = range(5)
    rows = [("expert-ppo/policy_latest", keep, keep),
            ("dagger_s0/policy_latest", keep, keep), ("dagger_s0/policy_latest", right, keep),
            ("dagger_s1/policy_latest", faster, keep), ("dagger_s1/policy_latest", keep, slower),
            ("bc_mlp_s0/policy_bc", slower, faster), ("bc_mlp_s0/policy_bc", keep, left)]
    decisions = pd.DataFrame(rows, columns=["policy", "action", "expert_action"])
    table = disagreement_kinds(decisions).set_index("method")
    assert list(table.index) == ["dagger", "bc_mlp"]  # the expert is no learner; seeds pool into one method
    assert table.loc["dagger", "decisions"] == 4 and table.loc["dagger", "disagreement"] == 0.75
    assert table.loc["dagger", "learner keeps"] == 0.5 and table.loc["dagger", "expert keeps"] == 0.75
    assert table.loc["dagger", "expert keeps, learner changes lane"] == pytest.approx(1 / 3)
    assert table.loc["dagger", "expert keeps, learner changes speed"] == pytest.approx(1 / 3)
    assert table.loc["dagger", "expert changes speed, learner keeps"] == pytest.approx(1 / 3)
    assert table.loc["bc_mlp", "expert changes lane, learner does not"] == 0.5
    assert table.loc["bc_mlp", "other"] == pytest.approx(0.5)  # accelerate against decelerate


def test_the_generalisation_table_pairs_each_mixed_method_with_its_own_road_run(tmp_path: Path):
    """(c)'s DAgger is compared with (a)'s DAgger, not its BC, on the same episodes; the expert's row is read from
    the (a) evaluation it drove in."""
    import pandas as pd
    from generalisation_table import expert_table, generalisation_table

    own = pd.read_parquet(Path(__file__).parent.parent / "docs/results/generalisation/data/a_exit.parquet")
    own.to_parquet(tmp_path / "a_exit.parquet")
    learners = own[own["policy"].str.startswith("dagger_")]
    learners.to_parquet(tmp_path / "c_exit.parquet")  # the same drivers: every (c) - (a) difference is 0
    lines = generalisation_table(tmp_path, {})
    mixed = {line.split(" | ")[1]: line for line in lines if "(c) every road" in line}
    assert set(mixed) == {"BC, mixed roads", "DAgger, mixed roads"}
    for line in mixed.values():
        assert line.rstrip(" |").split(" | ")[-1].startswith("+0.000 [+0.000, +0.000]")
    expert_rows = own[own["policy"].str.startswith("expert-")]
    assert f"| exit | {len(expert_rows)} |" in "\n".join(expert_table(tmp_path))


def test_rail_is_compared_with_bc_and_dagger_of_its_own_training_condition(tmp_path: Path):
    """(c)'s RAIL is paired with (c)'s BC and DAgger: the same drivers under both names give the same cells."""
    import pandas as pd
    from generalisation_table import rail_comparisons

    data = Path(__file__).parent.parent / "docs/results/generalisation/data"
    for condition in ("a", "c"):
        for prefix in ("", "rail_"):
            frame = pd.read_parquet(data / f"{prefix}a_merge.parquet")
            frame.to_parquet(tmp_path / f"{prefix}{condition}_merge.parquet")
    rows = {line.split(" | ")[1]: line.split(" | ", 2)[2] for line in rail_comparisons(tmp_path)[2:]}
    assert set(rows) == {"(a) merge", "(c) every road"}
    assert rows["(a) merge"] == rows["(c) every road"] and "[" in rows["(a) merge"]


def test_gail_is_read_beside_the_others_and_paired_with_rail(tmp_path: Path):
    """GAIL's evaluation of a road's (a) episodes (gail_a_KIND) gives GAIL's rows and the RAIL - GAIL cells: the
    RAIL drivers under GAIL's names differ from themselves by exactly 0."""
    import pandas as pd
    from generalisation_table import generalisation_table, rail_comparisons

    data = Path(__file__).parent.parent / "docs/results/generalisation/data"
    pd.read_parquet(data / "a_merge.parquet").to_parquet(tmp_path / "a_merge.parquet")
    rail = pd.read_parquet(data / "rail_a_merge.parquet")
    rail.to_parquet(tmp_path / "rail_a_merge.parquet")
    rail.assign(policy=rail["policy"].str.replace("rail_", "gail_")).to_parquet(tmp_path / "gail_a_merge.parquet")
    methods = {line.split(" | ")[1] for line in generalisation_table(tmp_path, {})[2:]}
    assert methods == {"BC", "DAgger", "RAIL", "GAIL"}
    (row,) = rail_comparisons(tmp_path)[2:]
    rail_minus_gail = row.rstrip(" |").split(" | ")[-1]
    assert rail_minus_gail.startswith("+0.000 [+0.000, +0.000]")



def test_each_road_s_safety_rows_are_paired_with_the_expert_on_the_same_episodes(tmp_path: Path):
    """A driver that is the expert under a method's names has the expert's safety measures and differs from it by
    exactly 0; the real drivers' rows carry their own measures."""
    import pandas as pd
    from generalisation_table import safety_table

    data = Path(__file__).parent.parent / "docs/results/generalisation/data"
    own = pd.read_parquet(data / "a_exit.parquet")
    expert = own[own["policy"].str.startswith("expert-")]
    copies = [expert.assign(policy=f"rail_s{seed}/policy_latest") for seed in range(3)]
    pd.concat([own, *copies]).to_parquet(tmp_path / "a_exit.parquet")
    rows = {line.split(" | ")[1]: line.rstrip(" |").split(" | ") for line in safety_table(tmp_path)[2:]}
    assert set(rows) == {"expert", "BC", "DAgger", "RAIL"}
    assert rows["RAIL"][-1] == " / ".join(["+0.00 [+0.00, +0.00] no detectable difference (per seed +0.00, +0.00, "
                                           "+0.00)"] * 3)
    assert rows["RAIL"][2].split(" ")[0] == rows["expert"][2].split(" ")[0]  # least TTC: the expert's own mean
    assert rows["BC"][2].split(" ")[0] != rows["expert"][2].split(" ")[0]


def test_thinned_tracks_keep_the_figure_s_seat_and_everything_the_table_reads():
    """docs/results commits the closed-loop tracks with positions only in the README figure's seat (issue 45)."""
    import pandas as pd
    from plot_scene_tracks import POSITIONS, chosen_seat, thin_tracks

    rows = []
    for vehicle, rail_end in (("a", 50.0), ("b", 90.0), ("c", 300.0)):
        for policy, lanes, end in (("human", [0, 1], 100.0), ("rail_s0/policy_bc", [0, 0], 100.0),
                                   ("rail_s0/policy_latest", [0, 1], rail_end)):
            lanes = [0, 0] if vehicle == "c" and policy == "human" else lanes  # c: the human kept its lane
            for step, lane in enumerate(lanes):
                rows.append({"policy": policy, "mode": "non-reactive", "scene": "s", "vehicle": vehicle,
                             "start_s": 10.0, "time_s": 10.0 + step, "x_m": end * step, "y_m": 1.0 * lane,
                             "lane_position_m": end * step, "speed_mps": 20.0 + step, "lane": lane, "gap_m": 5.0})
    tracks = pd.DataFrame(rows)
    thin = thin_tracks(tracks)
    assert chosen_seat(thin) == chosen_seat(tracks) == ("s", "a", 10.0)  # BC and RAIL end farthest apart in a
    kept = thin["vehicle"] == "a"
    assert thin.loc[kept, POSITIONS].equals(tracks.loc[kept, POSITIONS])
    assert thin.loc[~kept, POSITIONS].isna().all().all()
    others = [column for column in tracks.columns if column not in POSITIONS]
    assert thin[others].equals(tracks[others])


def test_ego_tracks_keep_the_ego_at_every_sumo_step_as_sumos_getters_read_it(small_config):
    """`ego_tracks.drive` (a `VehicleCapture` every step) keeps, on one short episode, the rows the validations kept
    before it: SUMO's getters read after every step of a swapped step function."""
    import pandas as pd
    from ego_tracks import TRACK_COLUMNS, drive

    from sumo_rail.sim.actions import Action
    from sumo_rail.sim.env import HighwayEnv
    from sumo_rail.sim.sumo_api import EGO_ID

    config = small_config.with_overrides({"env": {"max_episode_s": 6.0}})
    tracks, _, _ = drive(config, [3], "validation", lambda seed: lambda observation, env: (int(Action.KEEP),
                                                                                          {"lateral": 0}))
    env = HighwayEnv(config)
    try:
        env.reset(seed=3, options={"pool": "validation"})
        sim = env.simulation
        api, start_s, rows = sim._api, sim.time_s, []

        def read(time_s: float) -> dict:
            vehicle = api.vehicle
            x, y = vehicle.getPosition(EGO_ID)
            return {"time_s": round(time_s - start_s, 6), "x_m": x, "y_m": y, "heading_deg": vehicle.getAngle(EGO_ID),
                    "speed_mps": vehicle.getSpeed(EGO_ID), "acceleration_mps2": vehicle.getAcceleration(EGO_ID),
                    "edge": vehicle.getRoadID(EGO_ID), "lane": vehicle.getLaneIndex(EGO_ID),
                    "lane_position_m": vehicle.getLanePosition(EGO_ID), "length_m": vehicle.getLength(EGO_ID),
                    "width_m": vehicle.getWidth(EGO_ID), "vehicle_class": "passenger"}

        step = sim._calls.step

        def reading_step() -> None:
            step()
            if EGO_ID in api.vehicle.getIDList():
                rows.append(read(api.simulation.getTime()))

        rows.append(read(start_s))
        sim._calls = sim._calls._replace(step=reading_step)
        done = False
        while not done:
            _, _, terminated, truncated, _ = env.step(int(Action.KEEP))
            done = terminated or truncated
    finally:
        env.close()
    assert len(rows) > 50
    pd.testing.assert_frame_equal(tracks[list(TRACK_COLUMNS)], pd.DataFrame(rows), check_exact=True)


def test_the_figures_typical_seat_is_the_median_of_the_first_drivers_10_s_errors():
    import pandas as pd
    from plot_scene_tracks import median_seat

    rows = [{"policy": policy, "mode": mode, "scene": "s", "vehicle": f"v{k}", "start_s": 1.0,
             "position_error_10s_m": error}
            for k, error in enumerate([9.0, 1.0, 5.0, 7.0, 3.0, float("nan")])
            for policy, mode in (("log", "non-reactive"), ("log", "reactive"), ("other", "non-reactive"))]
    metrics = pd.DataFrame(rows)
    metrics.loc[metrics["mode"] == "reactive", "position_error_10s_m"] = 0.0  # the other mode is not read
    metrics.loc[metrics["policy"] == "other", "position_error_10s_m"] *= -1
    assert median_seat(metrics, "log") == ("s", "v2", 1.0)  # errors 1, 3, 5, 7, 9: 5 m is v2's


CLICK_SCRIPTS = sorted(path.stem for path in EXPERIMENTS.glob("*.py")
                       if 'if __name__ == "__main__":\n    cli()' in path.read_text())


def test_no_experiment_script_parses_its_arguments_by_hand():
    """A script reads its arguments with click (a usage message and exit 2 on a bad one), not off sys.argv: a missing
    or mistyped argument was an IndexError or ValueError traceback."""
    by_hand = [path.name for path in sorted(EXPERIMENTS.glob("*.py")) if re.search(r"sys\.argv\[", path.read_text())]
    assert by_hand == []
    assert len(CLICK_SCRIPTS) >= 30


@pytest.mark.parametrize("name", CLICK_SCRIPTS)
def test_an_experiment_script_refuses_a_bad_argument_with_its_usage_and_exit_2(name: str, tmp_path: Path):
    """An unknown option, a missing argument (for a script that needs one), an input file that is not there: a usage
    message and one sentence, exit 2 (a script's only argument that is an output folder is not tried: it is made)."""
    from click.testing import CliRunner

    command = __import__(name).cli
    needs = isinstance(command, click.Group) or any(parameter.required for parameter in command.params)
    missing = str(tmp_path / "missing.parquet")
    inputs = [parameter for parameter in command.params if isinstance(parameter.type, click.Path)
              and parameter.type.exists]
    cases = [["--no-such-option"], *([[]] if needs else []), *([[missing]] if inputs or isinstance(command, click.Group)
                                                                else [])]
    for arguments in cases:
        result = CliRunner().invoke(command, arguments)
        assert result.exit_code == 2 and isinstance(result.exception, SystemExit), (arguments, result.output)
        assert "Usage:" in result.output and ("Error: " in result.output or arguments == [])  # a group: its help
    assert not (tmp_path / "missing.parquet").exists()


def test_the_log_study_names_each_run_by_its_teacher_history_and_reading():
    from human_likeness_closed_loop import log_methods

    seeds = range(3)
    policies = {"keep", "sumo-idm-calibrated",
                *(f"log_t{teacher}{shown}_s{seed}/policy_{kind}" for teacher in (2, 5) for shown in ("", "_h3")
                  for seed in seeds for kind in ("bc", "latest")),
                *(f"log_t2_s{seed}/policy_latest (sampled at 0.6)" for seed in seeds)}
    methods = log_methods(policies)
    assert list(methods) == ["constant speed (keep)", "IDM calibrated on the train split", "BC", "BC, history 3 s",
                             "against the log, teacher 2 s", "against the log, teacher 2 s, sampled at 0.6",
                             "against the log, teacher 2 s, history 3 s", "against the log, teacher 5 s",
                             "against the log, teacher 5 s, history 3 s"]
    assert methods["BC, history 3 s"] == [f"log_t2_h3_s{seed}/policy_bc" for seed in seeds]
    assert methods["against the log, teacher 2 s, sampled at 0.6"] == [
        f"log_t2_s{seed}/policy_latest (sampled at 0.6)" for seed in seeds]


def test_the_log_study_pairs_rail_and_gail_in_seats_with_bc_the_baselines_and_training_against_the_log():
    """GAIL's runs in recorded seats (gail_seats_lRATE_sSEED) are a learner of the log study as RAIL's are: pooled
    over their seeds in order, each setting apart, and paired with BC, every baseline and training against the log."""
    from human_likeness_closed_loop import CALIBRATED, log_study

    seeds = (2, 0, 1)
    policies = {"keep", "sumo-idm-calibrated", *(f"log_t2_s{seed}/policy_{kind}" for seed in seeds
                                                 for kind in ("bc", "latest")),
                *(f"{run}_s{seed}/policy_latest" for run in ("rail_seats_a005", "gail_seats_l0003", "gail_seats_l0001")
                  for seed in seeds)}
    methods, differences, pooled = log_study(policies)
    gail, rail, log = "GAIL in seats, learning rate 0.0003", "RAIL in seats, step 0.005", "against the log, teacher 2 s"
    assert methods[gail] == [f"gail_seats_l0003_s{seed}/policy_latest" for seed in sorted(seeds)]
    assert methods["GAIL in seats, learning rate 0.0001"][0] == "gail_seats_l0001_s0/policy_latest"
    for learner in (gail, rail):
        assert {(learner, other) for other in ("BC", CALIBRATED, "constant speed (keep)", log)} <= set(differences)
    assert "GAIL in seats" in pooled and "RAIL in seats" in pooled
