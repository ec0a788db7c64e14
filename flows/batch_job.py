"""What a batch task is asked to do, :class:`BatchJob` (one flow's work on one batch of
assets), and what it returns, :class:`BatchOutput`.

A job names its flow; the flow's planning function (:data:`BATCH_FLOWS`) turns the job's
``options`` into the batch's :class:`flows.pipeline.BatchPlan`, which
:func:`flows.pipeline.execute` runs. A job travels as a plain dict
(:meth:`BatchJob.to_dict`), the form Prefect records as the task's parameter and Dask ships
to a worker, and carries absolute locations, since the worker may run on another host.
"""
from __future__ import annotations

import importlib
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING, Callable, Sequence

from graybox.stage_clock import StageClock

from flows.config import FleetConfig, load_config
from flows.discovery import AssetRef
from flows.results import AssetResult

if TYPE_CHECKING:  # pragma: no cover - typing only (the pipeline imports the batching, it this)
    from flows.pipeline import BatchPlan


@dataclass
class BatchOutput:
    """What a batch task returns: per asset its result, and its stages' seconds."""

    assets: list[AssetResult]
    stages: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"assets": [a.to_dict() for a in self.assets], "stages": self.stages}

    @classmethod
    def from_dict(cls, data: dict) -> "BatchOutput":
        return cls([AssetResult.from_dict(a) for a in data["assets"]], dict(data["stages"]))


@dataclass(frozen=True)
class BatchFlow:
    """How a flow's batches are run and named.

    Attributes
    ----------
    planner : str
        ``"module:name"`` of the function planning one batch,
        ``planner(config, refs, **options, clock=...) -> BatchPlan``.
    task_name : str
        The Prefect task's name.
    run_name : str
        Each task run's name (``{label}``: the batch's assets).
    """

    planner: str
    task_name: str
    run_name: str


#: The flows that run in batches, by the name a :class:`BatchJob` gives.
BATCH_FLOWS = {
    "nightly": BatchFlow("flows.nightly:plan_batch", "nightly-batch", "nightly {label}"),
    "baseline": BatchFlow("flows.baseline:plan_baseline_batch", "baseline-batch",
                          "baseline {label}"),
    "reanalysis": BatchFlow("flows.reanalyze:plan_reanalysis_batch", "reanalysis-batch",
                            "reanalyze {label}"),
}


@dataclass(frozen=True)
class BatchJob:
    """One flow's work on one batch of assets.

    Attributes
    ----------
    flow : str
        A key of :data:`BATCH_FLOWS`.
    config_path : str
        The fleet.toml, absolute.
    tracking_uri : str or None
        The registry's location when it overrides ``[mlflow] tracking_uri`` (absolute).
    refs : tuple of AssetRef
        The batch's assets (empty in the job a flow describes before cutting batches).
    options : dict
        The flow's own arguments (e.g. ``as_of``), JSON-friendly values.
    """

    flow: str
    config_path: str
    tracking_uri: str | None = None
    refs: tuple[AssetRef, ...] = ()
    options: dict = field(default_factory=dict)

    @classmethod
    def for_fleet(cls, flow: str, config: FleetConfig, tracking_uri: str | None,
                  **options) -> "BatchJob":
        """A flow's job over ``config``'s fleet, before it is cut into batches: the
        configuration's and the store's absolute locations (the store's only when
        ``tracking_uri`` overrides the configuration's)."""
        if flow not in BATCH_FLOWS:
            raise ValueError(f"no batch flow {flow!r}; known: {', '.join(BATCH_FLOWS)}")
        return cls(flow, str(config.path), config.tracking_uri if tracking_uri else None,
                   options=dict(options))

    def for_batch(self, refs: Sequence[AssetRef]) -> "BatchJob":
        """The same job on the batch ``refs``."""
        return replace(self, refs=tuple(refs))

    def to_dict(self) -> dict:
        return {"flow": self.flow, "config_path": self.config_path,
                "tracking_uri": self.tracking_uri, "refs": [asdict(r) for r in self.refs],
                "options": dict(self.options)}

    @classmethod
    def from_dict(cls, data: dict) -> "BatchJob":
        return cls(data["flow"], data["config_path"], data.get("tracking_uri"),
                   tuple(AssetRef(**r) for r in data.get("refs", ())),
                   dict(data.get("options", {})))

    def planner(self) -> Callable:
        """The flow's function planning one batch (imported here: the flows import this
        module)."""
        module, name = BATCH_FLOWS[self.flow].planner.split(":")
        return getattr(importlib.import_module(module), name)

    def plan(self, clock: StageClock | None = None) -> tuple[FleetConfig, BatchPlan]:
        """Load the configuration and plan the batch with the flow's planner.

        Parameters
        ----------
        clock : StageClock, optional
            Accumulates the seconds of the planning's stages.

        Returns
        -------
        config : FleetConfig
            The fleet.toml's configuration, on the job's registry.
        plan : BatchPlan
            The batch's plan, for :func:`flows.pipeline.execute`.
        """
        config = load_config(self.config_path).with_tracking_uri(self.tracking_uri)
        return config, self.planner()(config, list(self.refs), **self.options, clock=clock)

    def run(self) -> BatchOutput:
        """Plan the batch (:meth:`plan`) and execute the plan, as the batch task does with the
        job it is given (:func:`flows.batching.batch_task`).

        Returns
        -------
        BatchOutput
            One result per asset, in the order of ``refs``, and the seconds of the stages.
        """
        from flows.pipeline import execute   # the pipeline imports the batching, and it this

        clock = StageClock()
        config, plan = self.plan(clock)
        return BatchOutput(execute(config, plan, clock), clock.to_dict())
