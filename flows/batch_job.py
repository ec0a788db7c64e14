"""What a batch task is asked to do: :class:`BatchJob`, one flow's work on one batch of assets.

A job names its flow; the flow's batch function (:data:`BATCH_FLOWS`) processes the batch
with the job's ``options`` as keyword arguments. A job travels as a plain dict
(:meth:`BatchJob.to_dict`), the form Prefect records as the task's parameter and Dask ships
to a worker, and carries absolute locations, since the worker may run on another host.
"""
from __future__ import annotations

import importlib
from dataclasses import asdict, dataclass, field, replace
from typing import Callable, Sequence

from graybox.stage_clock import StageClock

from flows.config import FleetConfig, load_config
from flows.discovery import AssetRef


@dataclass(frozen=True)
class BatchFlow:
    """How a flow's batches are run and named.

    Attributes
    ----------
    function : str
        ``"module:name"`` of the function processing one batch,
        ``function(config, refs, **options, clock=...) -> list[AssetResult]``.
    task_name : str
        The Prefect task's name.
    run_name : str
        Each task run's name (``{label}``: the batch's assets).
    """

    function: str
    task_name: str
    run_name: str


#: The flows that run in batches, by the name a :class:`BatchJob` gives.
BATCH_FLOWS = {
    "nightly": BatchFlow("flows.nightly:process_batch", "nightly-batch", "nightly {label}"),
    "baseline": BatchFlow("flows.baseline:process_baseline_batch", "baseline-batch",
                          "baseline {label}"),
    "reanalysis": BatchFlow("flows.reanalyze:process_reanalysis_batch", "reanalysis-batch",
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

    def batch_function(self) -> Callable:
        """The flow's function processing one batch (imported here: the flows import this
        module)."""
        module, name = BATCH_FLOWS[self.flow].function.split(":")
        return getattr(importlib.import_module(module), name)

    def run(self, clock: StageClock | None = None) -> list:
        """Process the batch: load the configuration and call the flow's batch function.

        Returns
        -------
        list of AssetResult
            One per asset, in the order of ``refs``.
        """
        config = load_config(self.config_path).with_tracking_uri(self.tracking_uri)
        return self.batch_function()(config, list(self.refs), **self.options, clock=clock)
