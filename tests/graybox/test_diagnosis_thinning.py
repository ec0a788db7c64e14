"""A diagnosis on every other starting point (``thinning=2``): the same runs as a level tier
of twice the stride, its likelihood on the thinned errors' effective samples, and the
baseline's share of each interval counted at the level tier's own spacing."""
import numpy as np
import pytest

from graybox.diagnosis import diagnose_window
from graybox.integration import Integration
from graybox.parameter_estimation import ErrorSetup
from tests.graybox.test_diagnosis import DT, Drive, drive_frame, levels  # noqa: F401


def _setup(levels, stride: int) -> ErrorSetup:
    return ErrorSetup.default(DT, horizon=levels["speed"].horizon, stride=stride,
                              integration=Integration())


def test_thinning_runs_every_other_start_and_counts_the_baseline_at_its_spacing(levels):
    # the temperature sensor reads 0.3 K high: only the temperature's errors carry the bias
    # (the speed does not feel the temperature), so its interval's width is set by that
    # channel alone, sd^2 = (1 + n m / N_b) / (w sum (dr/db)^2 / sigma^2) with n the thinned
    # errors and m the thinning: against a level tier of twice the stride (m = 1, the same
    # runs, the same n) the width is sqrt((1 + 2 n / N_b) / (1 + n / N_b)) times as wide
    night = drive_frame(Drive(), 12, bias=(0.0, 0.3))
    full_stride = _setup(levels, 1).stride
    thinned = diagnose_window(Drive(), levels, [night], _setup(levels, full_stride),
                              thinning=2)
    doubled = diagnose_window(Drive(), levels, [night], _setup(levels, 2 * full_stride))
    assert thinned.n_obs == doubled.n_obs
    assert thinned.effective_samples == doubled.effective_samples
    ratio = thinned.n_obs / 2 / levels["temperature"].n_obs
    for a, b in zip(thinned.hypotheses, doubled.hypotheses):
        assert (a.hypothesis, a.estimate, a.score) == (b.hypothesis, b.estimate, b.score)
    best, other = thinned.hypotheses[0], doubled.hypotheses[0]
    assert (best.kind, best.target) == ("bias", "temperature")
    width = (best.interval[1] - best.interval[0]) / (other.interval[1] - other.interval[0])
    assert width == pytest.approx(np.sqrt((1 + 2 * ratio) / (1 + ratio)), rel=1e-9)


def test_a_thinned_diagnosis_keeps_the_fault_within_a_wider_interval(levels):
    night = drive_frame(Drive(), 12, bias=(0.0, 0.3))
    full = diagnose_window(Drive(), levels, [night])
    thinned = diagnose_window(Drive(), levels, [night], thinning=2)
    assert thinned.n_obs == pytest.approx(full.n_obs / 2, abs=2)
    best, alone = thinned.best, full.best
    assert (best.kind, best.target) == (alone.kind, alone.target) == ("bias", "temperature")
    assert best.interval[0] < 0.3 < best.interval[1]
    # the skipped starts' information is lost, not assumed: never narrower
    assert best.interval[1] - best.interval[0] >= alone.interval[1] - alone.interval[0]


@pytest.mark.parametrize("thinning", [0, 1.5])
def test_thinning_is_a_whole_number_of_at_least_one(levels, thinning):
    with pytest.raises(ValueError, match="thinning"):
        diagnose_window(Drive(), levels, [drive_frame(Drive(), 12)], thinning=thinning)
