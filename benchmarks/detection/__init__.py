"""Detection benchmark (issue #5): does the gray box beat thresholds on the same residuals?

``python -m benchmarks.detection [--quick] [--seeds N] [--out docs/benchmarks.md]`` simulates
fleets with faults (a) gamma drift, (b) flutter, (c) sensor noise, (d) bias at three
magnitudes each, with the white box 0, 10 and 20 % off; runs the classic detectors of the
paper's section I (3-sigma redline, adaptive threshold, CUSUM on mean and variance, GLR) and
the gray box on the same residuals, each calibrated per asset on the same K healthy days to
1 % false alarms per asset-night; and writes the report with tables, plots and raw CSV.

Modules: :mod:`~benchmarks.detection.grid` (scenario grid, simulation),
:mod:`~benchmarks.detection.classic` (detectors and their calibration),
:mod:`~benchmarks.detection.run` (the grid, in worker processes),
:mod:`~benchmarks.detection.metrics` (false alarms, detection rate, delay, AUC),
:mod:`~benchmarks.detection.report` (markdown, PNG, CSV),
:mod:`~benchmarks.detection.rates` (the reduced grid per sampling interval:
``python -m benchmarks.detection.rates``, a section of the same report).
"""
