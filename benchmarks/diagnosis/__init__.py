"""``python -m benchmarks.diagnosis``: which physical cause :func:`graybox.diagnose` ranks first
for the alarmed asset-nights of the gas-turbine detection grid (issue 19, item 4).

One concept per module: :mod:`~benchmarks.diagnosis.expected` (the hypothesis each grid fault
kind should produce and its true size, declared here and not in the product),
:mod:`~benchmarks.diagnosis.expected_zoo` (the same for two zoo families, and their tuned
parameters), :mod:`~benchmarks.diagnosis.grid_run` (simulate, tune, baseline, score nights,
diagnose), :mod:`~benchmarks.diagnosis.zoo_run` (the same on a zoo family),
:mod:`~benchmarks.diagnosis.scores` (accuracy, confusion, estimate errors, false causes, cost),
:mod:`~benchmarks.diagnosis.report` (the markdown section),
:mod:`~benchmarks.diagnosis.episode` (which nights an alarmed night is diagnosed on: its
candidate's, or with ``--evidence since-alarm``, an experiment, its alert episode's) and
:mod:`~benchmarks.diagnosis.by_night` (runs' top-1 and top-3 by night from the onset, side by
side). Results: docs/benchmarks.md,
"Diagnosis: which cause comes first".
"""
