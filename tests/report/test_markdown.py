"""`sumo-rail report` on small hand-made runs and metrics files written with the project's own writers (no SUMO)."""

import json
import struct
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pytest
from matplotlib.image import imread
from test_cli import invoke

from sumo_rail.config import Config
from sumo_rail.datasets import write_parquet
from sumo_rail.drivers.policies import Policy, PolicyShape, save_policy
from sumo_rail.runners.rollout import ACTION_COLUMNS
from sumo_rail.runners.tables import EPISODE_METRICS, METRIC_COLUMNS, metrics_table, provenance

CONFIG = Config()
OBSERVATIONS = 56


def make_run(folder: Path, kind: str, evaluated: bool, with_bc: bool = True, method: str = "training_run",
             agreement: bool = False) -> Path:
    """A run folder like `sumo-rail train` (or, with method "gail_run", `sumo-rail gail`) leaves: run.json, random
    policies and a 4-iteration log (with `agreement`, validation agreement columns as today's logs have)."""
    folder.mkdir()
    record = {"settings": {"kind": kind, "hidden": 6}, **provenance(method, CONFIG, 0)}
    (folder / "run.json").write_text(json.dumps(record))
    shape = PolicyShape(kind, OBSERVATIONS, hidden=6)
    rng = np.random.default_rng(len(folder.name))
    for file in ("policy_bc.npz",) * with_bc + ("policy_latest.npz", "policy_best.npz"):
        save_policy(Policy(shape, rng.normal(0, 0.3, shape.parameter_count)), folder / file, record)
    rows = [{"iteration": i, "env_steps": 1000 + 10 * i, "return_mean": -0.2 + 0.05 * i, "return_max": 0.1 * i,
             "return_std": 0.1, "nu": 0.03, "reward_std": 0.05, "discriminator_loss": 0.24,
             "discriminator_accuracy": 0.6, "collisions": 0, "wall_time_s": 12.0,
             **{column: (100.0 + i if evaluated and i % 2 else None)
                for column in ("eval_average_speed_kmh", "eval_overtakes", "eval_lane_changes",
                               "eval_longitudinal_reward", "eval_lateral_reward", "eval_collisions")},
             **({"eval_agreement": 0.5 + 0.1 * i if i % 2 else None,
                 "eval_lane_change_recall": 0.2 if i % 2 else None} if agreement else {})}
            for i in range(4)]
    table = pa.Table.from_pandas(pd.DataFrame(rows, dtype=float).astype({"iteration": int, "env_steps": int}),
                                 preserve_index=False)
    write_parquet(table, folder / "log.parquet", {**record, "kind": "training_log"})
    return folder


def make_metrics(path: Path, drivers: tuple[str, ...] = ("expert-normal", "policy_best")) -> Path:
    """An evaluation metrics file: 3 episodes per driver."""
    rng = np.random.default_rng(1)
    rows = []
    for driver in drivers:
        for episode in range(3):
            row = dict.fromkeys(METRIC_COLUMNS, 0)
            row.update({"policy": driver, "episode": episode, "seed": 3001 + 3 * episode, "steps": 200,
                        "simulated_s": 100.0, "distance_m": 2800.0, "average_speed_kmh": rng.uniform(90, 120),
                        "overtakes": int(rng.integers(0, 5)), "lane_changes": int(rng.integers(0, 6)),
                        "longitudinal_reward": rng.uniform(100, 150), "lateral_reward": -rng.uniform(0, 10),
                        "termination": "end_of_road", "terminated": False, "truncated": True,
                        **dict.fromkeys(ACTION_COLUMNS, 40)})
            rows.append(row)
    write_parquet(metrics_table(rows), path, provenance(EPISODE_METRICS, CONFIG, 1000))
    return path


def png_size(path: Path) -> tuple[int, int]:
    """(width, height) in pixels of a PNG, after checking its signature and that it decodes."""
    content = path.read_bytes()
    assert content[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = struct.unpack(">II", content[16:24])
    assert imread(path).shape[:2] == (height, width)
    return width, height


def test_report_of_runs_and_metrics_files(tmp_path):
    mlp = make_run(tmp_path / "mlp_run", "mlp", evaluated=True)
    linear = make_run(tmp_path / "linear_run", "linear", evaluated=False, with_bc=False)
    first, second = make_metrics(tmp_path / "m1.parquet"), make_metrics(tmp_path / "m2.parquet", ("expert-normal",))
    out = tmp_path / "report" / "nested"
    result = invoke("report", str(mlp), str(first), str(linear), str(second), "--out", str(out))
    assert result.exit_code == 0, result.output
    assert str(out / "report.md") in result.output
    pngs = ["learning_curves.png", "validation.png", "metrics.png", "differences.png", "weights_mlp_run.png",
            "weights_linear_run.png"]
    assert sorted(path.name for path in out.iterdir()) == sorted([*pngs, "report.md"])  # no temporary files left
    for name in pngs:
        width, height = png_size(out / name)
        assert 800 <= width <= 2500 and 500 <= height <= 2000, name
    report = (out / "report.md").read_text()
    for name in pngs:
        assert f"]({name})" in report
    assert "| mlp_run | straight | mlp (6 hidden) | 4 | 4,060 | 0.8 | -0.050 | -0.050 (4) | 4 | 103.0 |" in report
    assert "| linear_run | straight | linear | 4 |" in report and report.count("| - ") == 5
    assert "expert-normal [m1]" in report and "expert-normal [m2]" in report and "policy_best" in report
    assert "mean [95% interval]" in report and "difference to expert-normal [m1] on the same seeds" in report
    assert "predate the comparison with the expert" in report  # metrics files without confusion counts still load
    assert "agreement.png" not in report and "confusion.png" not in report


def test_validation_curves_lead_with_agreement_and_mark_older_logs(tmp_path):
    from sumo_rail.report.inputs import read_run
    from sumo_rail.report.plots import validation_curves

    today = read_run(make_run(tmp_path / "today", "mlp", evaluated=True, agreement=True), "today")
    older = read_run(make_run(tmp_path / "older", "mlp", evaluated=True), "older")
    agreement_panel = validation_curves([today, older]).axes[0]
    assert agreement_panel.get_title() == "agreement with the expert"
    assert np.allclose(agreement_panel.lines[0].get_ydata(), [0.6, 0.8])  # the evaluated iterations 1 and 3
    assert np.isnan(np.asarray(agreement_panel.lines[1].get_ydata(), dtype=float)).all()
    assert not agreement_panel.texts  # one run has it: no "not in these logs" note
    only_older = validation_curves([older]).axes[0]
    assert "not in these logs" in only_older.texts[0].get_text()


def test_no_validation_plot_without_validation_values(tmp_path):
    run = make_run(tmp_path / "run", "mlp", evaluated=False)
    result = invoke("report", str(run), "--out", str(tmp_path / "out"))
    assert result.exit_code == 0, result.output
    assert sorted(path.name for path in (tmp_path / "out").iterdir()) == [
        "learning_curves.png", "report.md", "weights_run.png"]
    assert "validation.png" not in (tmp_path / "out" / "report.md").read_text()


def _folder_without_log(tmp_path: Path) -> Path:
    (tmp_path / "empty").mkdir()
    return tmp_path / "empty"


def _demonstrations_kind(tmp_path: Path) -> Path:
    path = tmp_path / "demos.parquet"
    write_parquet(pa.table({"action": [0, 1]}), path, provenance("demonstrations", CONFIG, 0))
    return path


def _corrupt_file(tmp_path: Path) -> Path:
    path = tmp_path / "metrics.parquet"
    path.write_bytes(b"not parquet at all")
    return path


def _log_instead_of_folder(tmp_path: Path) -> Path:
    return make_run(tmp_path / "run", "linear", evaluated=False) / "log.parquet"


def _corrupt_policy(tmp_path: Path) -> Path:
    run = make_run(tmp_path / "run", "mlp", evaluated=False)
    (run / "policy_latest.npz").write_bytes(b"garbage")
    return run


@pytest.mark.parametrize(("make_input", "fragment"), [
    (_folder_without_log, "has no log.parquet"),
    (_demonstrations_kind, "not evaluation metrics"),
    (_corrupt_file, "not a readable Parquet file"),
    (_log_instead_of_folder, "pass its run folder"),
    (_corrupt_policy, "policy_latest.npz"),
])
def test_bad_input_is_a_one_sentence_error(tmp_path, make_input, fragment):
    out = tmp_path / "out"
    result = invoke("report", str(make_input(tmp_path)), "--out", str(out))
    assert result.exit_code == 1 and fragment in result.output
    assert result.output.startswith("Error: ") and result.output.count("\n") == 1
    assert "Traceback" not in result.output and isinstance(result.exception, SystemExit)
    assert not out.exists()


def test_missing_input_is_a_usage_error(tmp_path):
    result = invoke("report", str(tmp_path / "missing"), "--out", str(tmp_path / "out"))
    assert result.exit_code == 2 and "does not exist" in result.output


def test_policies_are_labelled_by_training_method_and_the_latest_is_shown(tmp_path):
    from sumo_rail.report.inputs import read_run

    rail = read_run(make_run(tmp_path / "rail", "mlp", evaluated=False), "rail")
    gail = read_run(make_run(tmp_path / "gail", "mlp", evaluated=False, method="gail_run"), "gail")
    assert list(rail.policies) == ["BC", "RAIL"] and list(gail.policies) == ["BC", "GAIL"]
    assert rail.policies["RAIL"][1] == "policy_latest.npz"


def test_a_ppo_run_is_labelled_by_the_environments_return_and_not_mixed_with_discriminator_runs(tmp_path):
    ppo = make_run(tmp_path / "ppo", "mlp", evaluated=False, method="ppo_run")
    result = invoke("report", str(ppo), "--out", str(tmp_path / "report"))
    assert result.exit_code == 0, result.output
    text = (tmp_path / "report" / "report.md").read_text()
    assert "| updates | env steps | wall time (min) | final env return | best env return (update) | validated at " \
        "update |" in text and "D return" not in text and "iteration" not in text.split("## Plots")[0]
    assert "train, dagger, gail or ppo" in invoke("report", "--help").output
    assert "Mean environment return" in text and "discriminator return" not in text
    log = pd.read_parquet(ppo / "log.parquet").assign(return_mean=float("nan"))  # no episode ended in any update
    write_parquet(pa.Table.from_pandas(log, preserve_index=False), ppo / "log.parquet",
                  {**provenance("ppo_run", CONFIG, 0), "kind": "training_log"})
    result = invoke("report", str(ppo), "--out", str(tmp_path / "report"))
    assert result.exit_code == 0, result.output
    assert "| 4 | 4,060 | 0.8 | - | - |" in (tmp_path / "report" / "report.md").read_text()
    rail = make_run(tmp_path / "rail", "mlp", evaluated=False)
    result = invoke("report", str(ppo), str(rail), "--out", str(tmp_path / "mixed"))
    assert result.exit_code == 1 and "Traceback" not in result.output
    assert f"{ppo} is a ppo run, whose return is the environment's reward, and {rail} returns a discriminator's" \
        in result.output


def test_a_report_of_a_road_with_a_feature_shows_its_route_measures():
    """The metrics files' own scenario says whether the route's rows belong in the summary (none failed on the
    straight road's file, so its rows stay out there)."""
    from sumo_rail.report.inputs import read_inputs
    from sumo_rail.report.markdown import markdown

    data = Path(__file__).parents[2] / "docs/results/generalisation/data"
    for road, route in (("exit", True), ("straight", False)):
        inputs = read_inputs([data / f"a_{road}.parquet"])
        assert inputs.route is route
        assert ("\nmissed_exits " in markdown(inputs, [])) is route


def test_a_dagger_run_is_reported_with_its_road_and_gails_updates_are_called_updates(tmp_path):
    dagger = make_run(tmp_path / "dagger", "mlp", evaluated=True, method="dagger_run")
    log = pd.read_parquet(dagger / "log.parquet").drop(columns=["return_mean", "return_max", "return_std"])
    exit_road = provenance("dagger_run", CONFIG.with_overrides({"scenario": {"kind": "exit"}}), 0)
    (dagger / "run.json").write_text(json.dumps({"settings": {"kind": "mlp", "hidden": 6}, **exit_road}))
    write_parquet(pa.Table.from_pandas(log, preserve_index=False), dagger / "log.parquet",
                  {**exit_road, "kind": "dagger_log"})
    result = invoke("report", str(dagger), "--out", str(tmp_path / "report"))
    assert result.exit_code == 0, result.output
    text = (tmp_path / "report" / "report.md").read_text()
    assert "| dagger | exit | mlp (6 hidden) | 4 | 4,060 | 0.8 | - | - | 3 | 103.0 |" in text  # rounds from 0
    assert "| rounds |" in text and "learning_curves.png" not in text and "validation.png" in text
    gail = make_run(tmp_path / "gail", "mlp", evaluated=False, method="gail_run")
    result = invoke("report", str(gail), "--out", str(tmp_path / "gail_report"))
    assert result.exit_code == 0, result.output
    table = (tmp_path / "gail_report" / "report.md").read_text().split("## Plots")[0]
    assert "| updates |" in table and "(update) | validated at update |" in table and "| iterations |" not in table
