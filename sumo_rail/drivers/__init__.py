"""Who drives: the rule-based expert (a pure function of the traffic view) and the numpy policies with their
file format.

May import: the top level and `sim`.
"""
