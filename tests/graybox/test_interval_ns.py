"""The grid step a window's timestamps give (graybox.telemetry.validation.interval_ns)."""
import numpy as np
import pytest

from graybox.telemetry import GridPolicy
from graybox.telemetry.validation import interval_ns


@pytest.mark.parametrize("step", [1, 250_000_000, 1_000_000_000, 1_000_123, 600_000_000_000])
def test_regular_rows_give_their_step(step):
    ts = 1_767_225_600 * 10 ** 9 + step * np.arange(86_400, dtype=np.int64)
    assert interval_ns(ts, GridPolicy()) == step
    assert interval_ns(ts[:2], GridPolicy()) == step


def test_a_missing_row_counts_as_two_steps_and_jitter_gives_the_nominal_step():
    second = 10 ** 9
    ts = second * np.arange(1000, dtype=np.int64)
    assert interval_ns(np.delete(ts, [10, 500, 501]), GridPolicy()) == second
    jitter = np.random.default_rng(0).integers(-200_000_000, 200_000_000, len(ts))
    assert interval_ns(ts + jitter, GridPolicy()) == second
    assert interval_ns(ts * 3 // 2 + jitter, GridPolicy()) == 1_500_000_000


def test_the_policy_s_step_wins_and_no_step_is_one_ns():
    ts = 10 ** 9 * np.arange(10, dtype=np.int64)
    assert interval_ns(ts, GridPolicy(sample_interval=2.5)) == 2_500_000_000
    assert interval_ns(np.zeros(5, dtype=np.int64), GridPolicy()) == 1
