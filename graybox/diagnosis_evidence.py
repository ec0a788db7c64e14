"""What a diagnosis' best hypotheses were fitted on and what each leaves, for a plot.

:func:`graybox.diagnosis.diagnose` fits every hypothesis to the window's residual against
the baseline, ``r(t) = e(t) - level - slopes . (z(t) - centre)`` per channel (the k-step
errors with the baseline's explanation taken out). :class:`DiagnosisEvidence` keeps, for the
best :data:`EVIDENCE_HYPOTHESES` hypotheses, what an engineer needs to see which one explains
the window: each channel's ``r(t)`` with the times of its predicted samples, and what
``r(t)`` each hypothesis leaves under its fitted value. The part a hypothesis explains is the
difference (:meth:`DiagnosisEvidence.explained`): it follows ``r(t)`` where the cause fits.

A noise hypothesis changes no prediction: what it leaves is ``r(t)`` itself; its evidence is
the window's one-step innovations (:mod:`graybox.innovation_spread`), not ``r(t)``.

Plain arrays held in memory for the caller (the registry draws them); never written with the
diagnosis' record (:attr:`graybox.diagnosis.Diagnosis.evidence` is left out of its JSON).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover - graybox.diagnosis imports this module
    from graybox.diagnosis import Hypothesis

#: the hypotheses whose fits a diagnosis keeps (best first)
EVIDENCE_HYPOTHESES = 3


@dataclass(frozen=True)
class ChannelResidual:
    """One channel's residual against the baseline over the window.

    Attributes
    ----------
    channel : str
        The model's output name.
    times : ndarray of shape (N,)
        When each predicted sample was measured: the window's index values (datetime64 in
        UTC for a time index).
    residual : ndarray of shape (N,)
        ``r(t)`` under the baseline white box (finite values only).
    residual_std : float
        The baseline's spread of ``r(t)`` (its level tier's ``residual_std``).
    """

    channel: str
    times: np.ndarray
    residual: np.ndarray
    residual_std: float


@dataclass(frozen=True)
class HypothesisFit:
    """What one fitted hypothesis leaves of every channel's residual.

    Attributes
    ----------
    hypothesis : Hypothesis
    remaining : tuple of ndarray
        Per channel of the evidence (same order and length as its ``residual``), ``r(t)``
        under the hypothesis' fitted value (a gain's in the sensor's units).
    """

    hypothesis: Hypothesis
    remaining: tuple[np.ndarray, ...]


@dataclass(frozen=True)
class DiagnosisEvidence:
    """The residual of an alarmed window and the fits of its best hypotheses.

    Attributes
    ----------
    channels : tuple of ChannelResidual
        Every output channel of the white box.
    fits : tuple of HypothesisFit
        The best hypotheses (at most :data:`EVIDENCE_HYPOTHESES`), best first.
    """

    channels: tuple[ChannelResidual, ...]
    fits: tuple[HypothesisFit, ...]

    def explained(self, fit: int, channel: int) -> np.ndarray:
        """The part of ``channel``'s residual that hypothesis ``fit`` explains:
        ``r(t)`` minus what it leaves (zero for a noise hypothesis)."""
        return self.channels[channel].residual - self.fits[fit].remaining[channel]

    def concerned(self) -> tuple[int, ...]:
        """The channels the fitted hypotheses are about, in the model's order: every channel
        for a parameter (it moves the whole prediction), the sensor's own for the others."""
        names = [c.channel for c in self.channels]
        if any(f.hypothesis.kind == "parameter" for f in self.fits):
            return tuple(range(len(names)))
        targets = {f.hypothesis.target for f in self.fits}
        return tuple(i for i, name in enumerate(names) if name in targets)
