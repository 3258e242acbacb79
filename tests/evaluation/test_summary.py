import numpy as np
import pandas as pd

from sumo_rail.evaluation.summary import closeness


def test_closeness_verdicts_between_two_drivers():
    rng = np.random.default_rng(3)
    seeds = np.arange(80)
    expert = rng.normal(2.4, 1.0, 80)
    frames = [pd.DataFrame({"policy": name, "seed": seeds, **{m: values for m in ("overtakes", "lane_changes")}})
              for name, values in (("expert", expert), ("rail", expert + rng.normal(0.05, 0.1, 80)),
                                   ("bc", expert + rng.normal(-1.0, 0.1, 80)))]
    metrics = pd.concat(frames, ignore_index=True)
    metrics["lane_changes"] = np.where(metrics["policy"] == "expert", 1.0, 1.0 + rng.normal(0, 0.01, len(metrics)))
    table = closeness(metrics, "rail", "bc", "expert").set_index("measure")
    assert table.loc["overtakes", "verdict"] == "closer"
    assert table.loc["lane_changes", "verdict"] == "no detectable difference"
    assert closeness(metrics, "bc", "rail", "expert").set_index("measure").loc["overtakes", "verdict"] == "further"
