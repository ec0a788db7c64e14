"""Benchmarks of fleet-health; each is run as a module from the repository root, e.g.
``python -m benchmarks.detection`` or ``python -m benchmarks.registry_bench``."""
