"""Speed and core-accuracy benchmarks: what `tools/bench`, `tools/bench-core`, `-detect` and `-sim` run.

Figures are CPU time and ratios to a baseline measured in the same run (the machines are noisy).
"""
