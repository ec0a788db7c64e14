"""``python -m benchmarks.diagnosis``: which physical cause :func:`graybox.diagnose` ranks first
for the alarmed asset-nights of the gas-turbine detection grid (issue 19, item 4).

One concept per module: :mod:`~benchmarks.diagnosis.expected` (the hypothesis each fault kind
should produce and its true size, declared here and not in the product),
:mod:`~benchmarks.diagnosis.grid_run` (simulate, tune, baseline, score nights, diagnose),
:mod:`~benchmarks.diagnosis.scores` (accuracy, confusion, estimate errors, cost) and
:mod:`~benchmarks.diagnosis.report` (the markdown section).
"""
