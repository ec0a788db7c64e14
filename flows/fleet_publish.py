"""Publishing the night's fleet heat map from the nightly flow.

After the night's summary is built, the view of the last :data:`DEFAULT_NIGHTS` nights
(:func:`flows.fleet_view.collect_view`, with tonight's statuses) is drawn
(:func:`flows.fleet_plot.heatmap_png`) and published twice:

* as a Prefect markdown artifact (key :data:`ARTIFACT_KEY`) on the flow run, the PNG
  inline as a ``data:`` URI (Prefect's UI renders it; ``create_image_artifact`` needs a
  URL the UI can reach);
* as artifacts of the night's fleet-level MLflow run in ``fleet-health/fleet``
  (:mod:`registry.fleet_nights`: ``fleet_heatmap.png``, ``fleet_view.json`` and
  ``night_statuses.json``, the coverage counts as metrics); a rerun of the night replaces
  them in the same run.

:func:`publish_or_note` never fails the night: an error is logged as a warning and noted in
the summary (``extra["fleet_view"]``).
"""
from __future__ import annotations

import json
import logging

from flows.fleet_view import (DEFAULT_NIGHTS, DEFAULT_TOP, VIEW_FILE, collect_view,
                              night_document)
from flows.html_report import png_data_uri
from flows.results import RunSummary
from flows.run_logger import run_logger

logger = logging.getLogger(__name__)

ARTIFACT_KEY = "fleet-health-fleet-view"
HEATMAP_FILE = "fleet_heatmap.png"


def publish_fleet_view(summary: RunSummary, config, nights: int = DEFAULT_NIGHTS,
                       top: int = DEFAULT_TOP) -> dict:
    """Draw and publish the heat map of the nights ending with the summary's night.

    Returns
    -------
    dict
        ``night``, ``fleet_run_id`` (the MLflow run), ``assets`` and ``flagged`` (rows of
        the view).
    """
    # matplotlib and prefect load when a night is published, not on import
    from prefect.artifacts import create_markdown_artifact

    from flows.fleet_plot import heatmap_png

    registry = config.registry()
    tonight = night_document(summary)
    view = collect_view(registry, tonight["night"], nights, tonight)
    png = heatmap_png(view, top)
    run_id = registry.publish_night(
        tonight["night"], tonight,
        {HEATMAP_FILE: png, VIEW_FILE: json.dumps(view.to_dict(), indent=1).encode()},
        metrics={key.replace(" ", "_"): value for key, value in tonight["coverage"].items()})
    flagged = sum(row.flagged for row in view.rows)
    coverage = ", ".join(f"{value} {key}" for key, value in tonight["coverage"].items() if value)
    create_markdown_artifact(
        f"### The fleet at a glance, nights {view.nights[0]} to {view.nights[-1]}\n\n"
        f"{coverage or 'no assets'}; {flagged} of {len(view.rows)} assets flagged "
        f"(an alarm, failed, stale, an unusable baseline or dormant).\n\n"
        f"![fleet heat map]({png_data_uri(png)})\n\n"
        f"The same picture is an artifact of MLflow run `{run_id}` "
        f"(experiment `fleet-health/fleet`).",
        key=ARTIFACT_KEY,
        description=f"Heat map of assets x nights up to {tonight['night']} (worst "
                    f"zeta/epsilon per asset-night).")
    return {"night": tonight["night"], "fleet_run_id": run_id, "assets": len(view.rows),
            "flagged": flagged}


def publish_or_note(summary: RunSummary, config) -> None:
    """:func:`publish_fleet_view`, with its outcome noted in ``summary.extra["fleet_view"]``;
    an error is a warning on the flow run's log, never a failed night."""
    try:
        note = publish_fleet_view(summary, config)
    except Exception as error:  # noqa: BLE001 - the picture must never fail the night
        message = f"the fleet heat map was not published: {type(error).__name__}: {error}"
        run_logger(logger).warning(message)
        summary.extra["fleet_view"] = {"published": False, "error": message}
    else:
        summary.extra["fleet_view"] = {"published": True, **note}

