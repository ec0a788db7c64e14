"""Notifications: a Prefect state hook that sends the night's outcome to a notification block.

Every fleet-health flow has :func:`notify_hook` as its ``on_completion``, ``on_failure`` and
``on_crashed`` hook. When ``fleet.toml`` names a block (``[notifications] block =
"slack-webhook/fleet-health"``; any Prefect notification block: Slack, Microsoft Teams,
e-mail, PagerDuty, a custom webhook), the hook sends a short message when a run raised
alerts, had failed assets, left assets unmonitored for a reason that fails the run (no
baseline, an unusable baseline, stale telemetry, dormant: every status outside
:data:`flows.results.SETTLED`), or crashed, and nothing when all was quiet. Without a block it
does nothing. Create the block once, e.g.::

    from prefect.blocks.notifications import SlackWebhook
    SlackWebhook(url="https://hooks.slack.com/services/...").save("fleet-health")

A hook never fails the run: its own errors are logged.
"""
from __future__ import annotations

import logging

from prefect.blocks.core import Block

from flows.config import DEFAULT_CONFIG, load_config
from flows.results import FAILED, SETTLED, run_summary
from flows.run_logger import run_logger

logger = logging.getLogger(__name__)


def compose_message(flow_name: str, summary: dict | None, state_name: str,
                    state_message: str | None) -> tuple[str, str] | None:
    """(subject, body) of the notification, or None when there is nothing to say.

    Parameters
    ----------
    flow_name : str
    summary : dict or None
        The flow run's result as Prefect hands it over: the run summary serialised
        (:meth:`flows.results.RunSummary.to_dict`, alerts as
        :meth:`graybox.alert.Alert.to_dict`), or None when the run left none. Only the
        fields the message shows are read, so a partial summary is enough.
    state_name, state_message : str
        The final state's name and message.
    """
    if summary is None:
        if state_name in ("Completed",):
            return None
        return (f"fleet-health: {flow_name} {state_name.lower()}",
                f"The {flow_name} flow run ended {state_name}: {state_message or 'no message'}")
    alerts = summary.get("alerts") or []
    assets = summary.get("assets", [])
    failed = [a for a in assets if a.get("status") == FAILED]
    unmonitored = [a for a in assets if a.get("status") not in (*SETTLED, FAILED)]
    if not alerts and not failed and not unmonitored:
        return None
    lines = []
    if alerts:
        assets = sorted({a["asset_id"] for a in alerts})
        lines.append(f"{len(alerts)} alert(s) on {len(assets)} asset(s): {', '.join(assets)}")
        for alert in sorted(alerts, key=lambda a: -(a.get("ratio") or 0))[:10]:
            lines.append(f"  {alert['asset_id']} {alert['window_start'][:10]} "
                         f"{alert['channel']}/{alert['tier']}: zeta/epsilon "
                         f"{alert['ratio']:.2f} ({alert['severity']})")
    if failed:
        lines.append(f"{len(failed)} asset(s) failed:")
        for asset in failed[:10]:
            reason = (asset.get("error") or {}).get("message") or ""
            lines.append(f"  {asset['asset_id']}: {reason}")
    if unmonitored:
        lines.append(f"{len(unmonitored)} asset(s) not monitored:")
        for asset in unmonitored[:10]:
            note = asset.get("note") or ""
            lines.append(f"  {asset['asset_id']} ({asset['status']})" + (f": {note}" if note
                                                                       else ""))
    subject = f"fleet-health {flow_name}: {len(alerts)} alert(s), {len(failed)} failure(s)" + (
        f", {len(unmonitored)} not monitored" if unmonitored else "")
    return subject, "\n".join(lines)


def notify_hook(flow, flow_run, state) -> None:
    """Prefect state hook: notify the configured block (see the module docstring)."""
    try:
        config_path = (flow_run.parameters or {}).get("config_path", DEFAULT_CONFIG)
        block_slug = load_config(config_path).notifications.block
        if not block_slug:
            return
        summary = None
        try:
            result = run_summary(state)
            summary = result if isinstance(result, dict) else None
        except Exception:  # noqa: BLE001 - no result (crash): use the state's message
            summary = None
        message = compose_message(flow.name, summary, state.name, state.message)
        if message is None:
            return
        block = Block.load(block_slug)
        subject, body = message
        block.notify(body=body, subject=subject)
    except Exception:  # noqa: BLE001 - a notification never fails the run
        run_logger(logger).exception("fleet-health: could not send the notification")
