"""The plant zoo: plant families written for the benchmark, independent of the project's white
boxes and simulator, to measure whether the gray box's defaults hold on plants it was not
tuned on (``python -m benchmarks.zoo``; docs/benchmarks.md, "The plant zoo")."""
