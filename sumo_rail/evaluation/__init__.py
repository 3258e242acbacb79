"""Scoring drivers on held-out episodes: the paper's metrics per episode and the summary table.

May import: the top level, `sim`, `drivers` and `runners`.
"""
