"""SKAB (Skoltech Anomaly Benchmark): the gray box on a real pump testbed (issue 20).

The data is GPL-3.0 and is never copied into this repository: it is read from
``../shared/datasets/skab`` (relative to the repository root) or a path the user gives.
"""
