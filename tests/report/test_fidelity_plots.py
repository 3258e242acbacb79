"""`sumo-rail report` on a real evaluation: the fidelity figures and tables."""

import pandas as pd
from test_cli import SMALL, invoke
from test_markdown import png_size


def test_report_draws_agreement_confusion_distributions_and_differences(tmp_path):
    metrics = tmp_path / "metrics.parquet"
    result = invoke("evaluate", *SMALL, "--policy", "expert", "--policy", "keep", "--policy", "random",
                    "--episodes", "3", "--out", str(metrics))
    assert result.exit_code == 0, result.output
    out = tmp_path / "report"
    result = invoke("report", str(metrics), "--out", str(out))
    assert result.exit_code == 0, result.output
    pngs = ["metrics.png", "agreement.png", "confusion.png", "distributions.png", "differences.png"]
    assert sorted(path.name for path in out.iterdir()) == sorted([*pngs, "report.md"])
    for name in pngs:
        width, height = png_size(out / name)
        assert 600 <= width <= 2500 and 400 <= height <= 2500, name
    report = (out / "report.md").read_text()
    assert "Distances of each driver's distributions to expert-normal's" in report
    assert "predate" not in report and "difference to expert-normal on the same seeds" in report


def test_report_without_the_decisions_file_skips_the_distributions(tmp_path):
    metrics = tmp_path / "metrics.parquet"
    assert invoke("evaluate", *SMALL, "--policy", "expert", "--policy", "keep", "--episodes", "2",
                  "--out", str(metrics)).exit_code == 0
    (tmp_path / "metrics.decisions.parquet").unlink()
    out = tmp_path / "report"
    result = invoke("report", str(metrics), "--out", str(out))
    assert result.exit_code == 0, result.output
    assert not (out / "distributions.png").exists() and (out / "agreement.png").exists()
    assert len(pd.read_parquet(metrics)) == 4


def test_a_report_from_the_decision_summary_is_the_report_from_the_decisions(tmp_path):
    """docs/results commits NAME.distributions.parquet in place of NAME.decisions.parquet (issue 45): the report
    reads the same distances and histograms from it."""
    from sumo_rail.evaluation.distributions import decision_summary, summary_path

    metrics = tmp_path / "metrics.parquet"
    assert invoke("evaluate", *SMALL, "--policy", "expert", "--policy", "keep", "--episodes", "2",
                  "--out", str(metrics)).exit_code == 0
    assert invoke("report", str(metrics), "--out", str(tmp_path / "from_decisions")).exit_code == 0
    decisions = pd.read_parquet(tmp_path / "metrics.decisions.parquet")
    decision_summary(decisions, "expert-normal", int(decisions["lane"].max()) + 1).to_parquet(summary_path(metrics))
    (tmp_path / "metrics.decisions.parquet").unlink()
    result = invoke("report", str(metrics), "--out", str(tmp_path / "from_summary"))
    assert result.exit_code == 0, result.output
    assert (tmp_path / "from_summary" / "distributions.png").exists()
    assert ((tmp_path / "from_summary" / "report.md").read_text()
            == (tmp_path / "from_decisions" / "report.md").read_text())
