"""Print the environment decisions a training run used (the sum of env_steps in its log.parquet), the budget GAIL is
given to match it.

Usage: python experiments/env_steps.py RUN_FOLDER/log.parquet
"""

from __future__ import annotations

import sys

import pandas as pd

if __name__ == "__main__":
    print(int(pd.read_parquet(sys.argv[1], columns=["env_steps"])["env_steps"].sum()))
