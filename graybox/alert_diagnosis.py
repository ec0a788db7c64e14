"""A window's physical diagnosis as the run record and the alerts carry it.

:func:`graybox.diagnosis.diagnose` ranks the fault hypotheses of an alarmed window
(:class:`graybox.diagnosis.Diagnosis`); the pipeline records it with the candidate run
(``diagnosis.json`` and the tags ``fleet_health.diagnosis`` and
``fleet_health.likely_cause``) and hands it to every alert of the window as
:attr:`graybox.alert.Alert.diagnosis`. A diagnosis that could not be made is a
:class:`DiagnosisFailure`: recorded and shown as such, never dropped.

The alert's ``diagnosis`` is a ranked tuple of plain dicts, each ``{hypothesis, kind, target,
baseline, estimate, interval, score}`` (``interval`` a ``[low, high]`` list; ``since``
too when the change was fitted from a later night of the candidate's span:
:attr:`graybox.diagnosis.Hypothesis.since`; ``bound`` too, ``"upper"`` or ``"lower"``, when
the data do not bound a positive parameter or a gain on that side:
:attr:`graybox.diagnosis.Hypothesis.bound`), at most :data:`ALERT_HYPOTHESES` of them:

* **explained** (the best hypothesis scores above the diagnosis' ``min_score``): the best
  hypotheses, best first; ``diagnosis[0]`` is the likely cause.
* **no single cause** (none scores above it): first the marker ``{"hypothesis": "no single
  cause explains it", "kind": "none", "score": min_score}`` (the other keys None), then the
  best of the hypotheses, kept for inspection: every one of them scores below "healthy", so
  the marker ranks above them.
* **failed**: one entry ``{"hypothesis": "diagnosis failed: <reason>", "kind": "failed"}``
  (the other keys None).
* **not diagnosed** (no alarm, a stale-telemetry alert, a run recorded before diagnoses
  existed): ``()``.

Each writer has its reader here: :func:`diagnosis_document` / :func:`entries_from_document`
for ``diagnosis.json``, :func:`alert_entries` for the alerts, :func:`cause_text` for the
``likely cause`` (the tag and the run table's column).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

if TYPE_CHECKING:  # pragma: no cover - the alert record loads without scipy
    from graybox.diagnosis import Diagnosis, Hypothesis

#: the hypotheses an alert carries (``diagnosis.json`` holds them all)
ALERT_HYPOTHESES = 5
NO_SINGLE_CAUSE = "no single cause explains it"
EXPLAINED, UNEXPLAINED, FAILED = "explained", "unexplained", "failed"
STATUSES = (EXPLAINED, UNEXPLAINED, FAILED)
NONE_KIND, FAILED_KIND = "none", "failed"   #: the kinds of the two markers
ENTRY_KEYS = ("hypothesis", "kind", "target", "baseline", "estimate", "interval", "score")


@dataclass(frozen=True)
class DiagnosisFailure:
    """Why an alarmed window has no diagnosis.

    Attributes
    ----------
    reason : str
        The error, e.g. ``"InsufficientDataError: the baseline has no level tier ..."``.
    """

    reason: str


def _number(value) -> float | None:
    """A finite float, else None (JSON has no infinity)."""
    return float(value) if value is not None and math.isfinite(float(value)) else None


def hypothesis_entry(hypothesis: Hypothesis) -> dict[str, Any]:
    """One hypothesis as an alert's dict (non-finite numbers as None)."""
    low, high = hypothesis.interval
    entry = {"hypothesis": hypothesis.hypothesis, "kind": hypothesis.kind,
             "target": hypothesis.target, "baseline": _number(hypothesis.baseline),
             "estimate": _number(hypothesis.estimate), "interval": [_number(low), _number(high)],
             "score": _number(hypothesis.score)}
    if hypothesis.since is not None:      # fitted from a later night of the candidate's span
        entry["since"] = hypothesis.since
    if hypothesis.bound is not None:      # the data do not bound it on that side
        entry["bound"] = hypothesis.bound
    return entry


def _marker(text: str, kind: str, score: float | None = None) -> dict[str, Any]:
    return {"hypothesis": text, "kind": kind, "target": None, "baseline": None,
            "estimate": None, "interval": None, "score": score}


def status(diagnosis: Diagnosis | DiagnosisFailure) -> str:
    """``explained``, ``unexplained`` or ``failed``."""
    if isinstance(diagnosis, DiagnosisFailure):
        return FAILED
    return EXPLAINED if diagnosis.explained else UNEXPLAINED


def diagnosis_document(diagnosis: Diagnosis | DiagnosisFailure) -> dict[str, Any]:
    """``diagnosis.json``: the status, the likely cause, the error (failed) and every
    hypothesis ranked, each with its log-likelihood gain."""
    if isinstance(diagnosis, DiagnosisFailure):
        return {"status": FAILED, "likely_cause": cause_text(failure_entry(diagnosis.reason)),
                "error": diagnosis.reason, "hypotheses": []}
    hypotheses = [dict(hypothesis_entry(h), log_likelihood_gain=_number(h.log_likelihood_gain))
                  for h in diagnosis.hypotheses]
    document = {"status": status(diagnosis), "likely_cause": "", "error": None,
                "explained": diagnosis.explained, "min_score": diagnosis.min_score,
                "channels": list(diagnosis.channels), "n_obs": diagnosis.n_obs,
                "effective_samples": _number(diagnosis.effective_samples),
                "hypotheses": hypotheses}
    entries = entries_from_document(document)
    document["likely_cause"] = cause_text(entries[0]) if entries else ""
    return document


def failure_entry(reason: str) -> dict[str, Any]:
    """The single entry of a failed diagnosis."""
    return _marker(f"diagnosis failed: {reason}", FAILED_KIND)


def entries_from_document(document: Mapping[str, Any]) -> tuple[dict, ...]:
    """An alert's ``diagnosis`` from a ``diagnosis.json`` document (see the module
    docstring).

    Raises
    ------
    KeyError, TypeError, ValueError
        If the document is malformed.
    """
    state = document["status"]
    if state not in STATUSES:
        raise ValueError(f"diagnosis status must be one of {STATUSES}, got {state!r}")
    if state == FAILED:
        return (failure_entry(str(document.get("error") or "unknown reason")),)
    ranked = [{**{key: entry[key] for key in ENTRY_KEYS},
               **{key: entry[key] for key in ("since", "bound") if entry.get(key)}}
              for entry in document["hypotheses"]]
    if state == EXPLAINED:
        return tuple(ranked[:ALERT_HYPOTHESES])
    marker = _marker(NO_SINGLE_CAUSE, NONE_KIND, _number(document.get("min_score", 0.0)))
    return (marker, *ranked[:ALERT_HYPOTHESES - 1])


def alert_entries(diagnosis: Diagnosis | DiagnosisFailure | None) -> tuple[dict, ...]:
    """An alert's ``diagnosis`` (``()`` without one)."""
    return () if diagnosis is None else entries_from_document(diagnosis_document(diagnosis))


def cause_text(entry: Mapping[str, Any] | None) -> str:
    """The likely cause in a line: ``parameter inertia 50 -> 33.4 (-33 %; interval 33.1 to
    33.7)``, ``shaft_speed sensor bias 0 -> 0.52 (interval 0.47 to 0.57)``, ``no single cause
    explains it``, ``diagnosis failed: ...``, or ``""`` (no diagnosis)."""
    if not entry:
        return ""
    if entry.get("kind") in (NONE_KIND, FAILED_KIND):
        return str(entry["hypothesis"])
    baseline, estimate = entry.get("baseline"), entry.get("estimate")
    text = str(entry["hypothesis"])
    if estimate is None:
        return text
    text += f" {_g(baseline)} -> {_g(estimate)}"
    low, high = entry.get("interval") or (None, None)
    span = f"interval {_g(low)} to {_g(high)}"
    since = f" since {entry['since']}" if entry.get("since") else ""
    if entry.get("bound"):
        span += f", not bounded {'above' if entry['bound'] == 'upper' else 'below'}"
    if baseline and entry.get("kind") == "parameter":
        return text + f" ({(estimate - baseline) / baseline:+.0%}; {span}){since}"
    return text + f" ({span}){since}"


def _g(value) -> str:
    return "?" if value is None else f"{value:.4g}"
