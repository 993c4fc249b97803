"""Accuracy against ground truth: what `tools/evaluate`, `tools/track-gates` and `tools/horizon-offset` run.

`report` (the per-range-bin tables), `metrics` (IMO shares against bridge and hull), `diagnose`
(the error split by ray casting into the simulated ships), `stages` (the thesis's stages beside
the product on the same pairs), `gates`, `horizon`, `budget_plots` and `geometry_demo`.
"""
