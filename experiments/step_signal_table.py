"""The meter's table and figure (issue 25): every report written by `sumo-rail step-signal --out` in a folder.

Usage: python experiments/step_signal_table.py REPORTS_DIR [FIGURE.png]
Prints Markdown: a condensed table (per setting, the agreement's own signal, the paper's discriminator and the best
aligned other), then per setting the agreement's own signal (what the best possible reward, agreement with the
expert itself, would give the search) and each discriminator's signal and alignment; then the step cosines that
other ARS step settings (b = N, centred ranks) give on the same rollouts, from the returns the reports keep.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click
import numpy as np

from sumo_rail.learning.rail.noise import directions
from sumo_rail.learning.rail.step_signal import Differences, signal

STEP_SETTINGS = (("b = N / 2, std", 0.5, "std"), ("b = N, std", 1.0, "std"), ("b = N / 2, ranks", 0.5, "rank"),
                 ("b = N, ranks", 1.0, "rank"))
"""(label, b as a share of N, fitness shaping) of the step-cosine table."""


def estimate(value: dict[str, float]) -> str:
    """'+0.12 [-0.05, +0.30]', bold where the interval excludes 0."""
    text = f"{value['value']:+.2f} [{value['low']:+.2f}, {value['high']:+.2f}]"
    return f"**{text}**" if value["low"] > 0 or value["high"] < 0 else text


def describe(report: dict[str, Any]) -> str:
    """The setting in words: start, nu (or flip rate), episodes per rollout (or decisions on K respawning egos),
    traffic."""
    rail = report["settings"]["rail"]
    start = "zero" if report["zero_weights"] else "BC"
    noise = f"flip rate {rail['flip_rate']:g}" if rail["flip_rate"] is not None else f"nu {rail['noise']['initial']:g}"
    traffic = ", common traffic" if rail["common_traffic"] else ""
    rollout = (f"{rail['rollout_decisions']} dec. on {rail['egos']} respawning egos" if rail.get("rollout_decisions")
               else f"{rail['episodes_per_rollout']} ep.")
    return f"{start}, N {rail['directions']}, {noise}, {rollout}{traffic}"


def order(report: dict[str, Any]) -> tuple[Any, ...]:
    """Rows from BC to zero weights, then by noise, episodes per rollout, traffic and N."""
    rail = report["settings"]["rail"]
    return (report["zero_weights"], rail["flip_rate"] or 0.0, rail["episodes_per_rollout"], rail["common_traffic"],
            rail["directions"])


def load(folder: Path) -> list[tuple[str, dict[str, Any]]]:
    """(file stem, report) of every report in `folder`, by name."""
    reports = [(path.stem, json.loads(path.read_text())) for path in folder.glob("*.json")]
    return sorted(reports, key=lambda named: order(named[1]))


def main_table(reports: list[tuple[str, dict[str, Any]]]) -> str:
    lines = ["| setting | nu | decisions changed | agreement | signal of agreement itself | reward | signal of the "
             "reward | alignment across draws | alignment: step cosine |", "|---|---:|---:|---:|---|---|---|---|---|"]
    for _, report in reports:
        first = True
        for name, reward in report["rewards"].items():
            head = (f"| {describe(report)} | {report['nu']:.3g} | {report['flip_rate']:.1%} | "
                    f"{report['agreement_mean']:.3f} | {estimate(report['agreement']['correlation'])} "
                    if first else "| | | | | ")
            aligned = reward["alignment"]
            lines.append(f"{head}| {name} | {estimate(reward['signal']['correlation'])} | "
                         f"{estimate(aligned['across'])} | {estimate(aligned['step_cosine'])} |")
            first = False
    return "\n".join(lines)


def condensed_table(reports: list[tuple[str, dict[str, Any]]]) -> str:
    """Per setting: the agreement's own signal, the paper's discriminator ("given") and the best aligned other."""
    lines = ["| setting | decisions changed | agreement | signal of agreement itself | paper's reward: signal | "
             "paper's reward: alignment | best aligned other reward |", "|---|---:|---:|---|---|---|---|"]
    for _, report in reports:
        given = report["rewards"]["given"]
        others = {name: reward for name, reward in report["rewards"].items() if name != "given"}
        best = max(others, key=lambda name: others[name]["alignment"]["across"]["value"])
        lines.append(f"| {describe(report)} | {report['flip_rate']:.1%} | {report['agreement_mean']:.3f} | "
                     f"{estimate(report['agreement']['correlation'])} | {estimate(given['signal']['correlation'])} | "
                     f"{estimate(given['alignment']['across'])} | {best}: "
                     f"{estimate(others[best]['alignment']['across'])} |")
    return "\n".join(lines)


def step_table(reports: list[tuple[str, dict[str, Any]]]) -> str:
    """Cosine between the two draws' steps of the agreement itself under each step setting."""
    lines = ["| setting | " + " | ".join(label for label, _, _ in STEP_SETTINGS) + " |",
             "|---|" + "---|" * len(STEP_SETTINGS)]
    for _, report in reports:
        rail = report["settings"]["rail"]
        size = len(report["returns"]["agreement"]["plus"][0])
        parameters = _parameter_count(report)
        deltas = directions(rail["seed"], 0, size, parameters)
        measure = Differences(*(np.array(report["returns"]["agreement"][key]) for key in ("plus", "minus")))
        cells = [estimate(signal(deltas, measure, max(1, round(share * size)), shaping)["step_cosine"].to_dict())
                 for _, share, shaping in STEP_SETTINGS]
        lines.append(f"| {describe(report)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _parameter_count(report: dict[str, Any]) -> int:
    from sumo_rail.drivers.policies import load_policy

    return load_policy(Path(report["policy"]))[0].shape.parameter_count


def figure(reports: list[tuple[str, dict[str, Any]]], path: Path) -> None:
    """Signal (x) against alignment across draws (y) of every reward in every setting, with their intervals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    markers = dict(zip(["given", "contrast", "balanced", "balanced-contrast", "penalty"], "osD^v", strict=True))
    figure_, axis = plt.subplots(figsize=(9, 6))
    colours = plt.cm.tab10(np.arange(len(reports)) % 10)
    for colour, (_, report) in zip(colours, reports, strict=True):
        for name, reward in report["rewards"].items():
            x, y = reward["signal"]["correlation"], reward["alignment"]["across"]
            axis.errorbar(x["value"], y["value"], xerr=[[x["value"] - x["low"]], [x["high"] - x["value"]]],
                          yerr=[[y["value"] - y["low"]], [y["high"] - y["value"]]], fmt=markers.get(name, "o"),
                          color=colour, alpha=0.8, capsize=2,
                          label=describe(report) if name == next(iter(report["rewards"])) else None)
    for name, marker in markers.items():
        axis.plot([], [], marker, color="grey", label=f"reward: {name}")
    axis.axhline(0, color="black", lw=0.8)
    axis.axvline(0, color="black", lw=0.8)
    axis.set_xlabel("signal: correlation of r+ - r- between two traffic draws")
    axis.set_ylabel("alignment: correlation with the agreement difference (across draws)")
    axis.set_title("Where RAIL's step points: a reward leads to the expert only in the upper right")
    axis.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    figure_.tight_layout()
    figure_.savefig(path, dpi=120)


def main(folder: str, figure_path: str | None = None) -> None:
    reports = load(Path(folder))
    print(condensed_table(reports))
    print()
    print(main_table(reports))
    print()
    print(step_table(reports))
    if figure_path:
        figure(reports, Path(figure_path))


@click.command(help=__doc__)
@click.argument("folder", type=click.Path(exists=True, file_okay=False))
@click.argument("figure_path", required=False, type=click.Path(dir_okay=False))
def cli(folder: str, figure_path: str | None) -> None:
    main(folder, figure_path)


if __name__ == "__main__":
    cli()
