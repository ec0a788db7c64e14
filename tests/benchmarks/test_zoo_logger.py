"""The zoo through another logger: a 5-minute heated room is baselined and scored (it failed
every read before a stuck sensor needed 10 equal samples), and the logger does what it says."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from benchmarks.zoo.families import discover
from benchmarks.zoo.logger import Logger, LoggedFamily, main
from benchmarks.zoo.run import START, plan_fleet


def test_logger_settings_parse_and_refuse_unknown_ones():
    assert Logger.parse("every=5,jitter=0.2,drop=0.02") == Logger(5, 0.2, 0.02)
    assert Logger.parse("spike=0.001") == Logger(spike=0.001)
    assert Logger.parse("resend=0.5") == Logger(resend=0.5)
    assert Logger.parse("") == Logger()
    with pytest.raises(ValueError, match="unknown logger settings"):
        Logger.parse("rate=5")


def test_the_logger_keeps_every_kth_sample_moves_and_drops_rows():
    family = discover()["thermal_room"]                  # 60-s samples
    vehicles, _ = plan_fleet(family, 1, 0, 1, 1)
    plain = family.simulate(vehicles, START, 3)[vehicles[0].asset_id]
    logged = LoggedFamily(family, Logger(every=2, jitter=0.2, drop=0.1))
    frame = logged.simulate(vehicles, START, 3)[vehicles[0].asset_id]
    assert logged.sample_interval == 120.0
    kept = plain.iloc[::2]
    assert 0.85 * len(kept) < len(frame) < 0.95 * len(kept)
    nominal = kept.index[kept.index.get_indexer(frame.index, method="nearest")]
    shift = (frame.index - nominal).total_seconds()
    assert np.abs(shift).max() <= 0.2 * 120 + 1e-3 and np.abs(shift).max() > 12.0
    assert frame.index.name == plain.index.name


def test_the_logger_adds_glitches_of_3_to_8_standard_deviations_to_moving_channels():
    family = discover()["thermal_room"]
    vehicles, _ = plan_fleet(family, 1, 0, 1, 1)
    plain = family.simulate(vehicles, START, 3)[vehicles[0].asset_id]
    frame = LoggedFamily(family, Logger(spike=0.01)).simulate(vehicles, START, 3)[
        vehicles[0].asset_id]
    assert frame.index.equals(plain.index)
    for column in plain.columns:
        moved = (frame[column] - plain[column]).abs().to_numpy() / plain[column].std(ddof=0)
        if plain[column].nunique() <= 10:              # a flag or a setpoint: untouched
            assert not moved.any(), column
            continue
        hit = moved > 0
        assert 0.005 < hit.mean() < 0.02, column       # about 1 % of the readings
        assert moved[hit].min() >= 3.0 - 1e-9 and moved[hit].max() <= 8.0 + 1e-9, column


def test_the_logger_loses_rows_and_readings_for_10_to_60_minutes_a_day():
    family = discover()["thermal_room"]                  # 60-s samples
    vehicles, _ = plan_fleet(family, 1, 0, 1, 1)
    plain = family.simulate(vehicles, START, 4)[vehicles[0].asset_id]
    frame = LoggedFamily(family, Logger(outage=1.0, dropout=1.0)).simulate(vehicles, START, 4)[
        vehicles[0].asset_id]
    steps = (frame.index[1:] - frame.index[:-1]).total_seconds().to_numpy() / 60.0
    # an outage a day (two may join across midnight): 10-60 missing minutes each
    outages = steps[steps > 1] - 1
    assert 3 <= len(outages) <= 4 and outages.min() >= 9 and outages.max() <= 120
    assert len(plain) - len(frame) == outages.sum()
    # a channel's readings lost for 10-60 minutes a day; the rest as simulated
    lost = frame.isna()
    assert 4 * 10 <= lost.to_numpy().sum() <= 4 * 60
    pd.testing.assert_frame_equal(frame[~lost.any(axis=1)], plain.loc[frame.index][~lost.any(axis=1)])


def test_the_logger_resends_10_to_60_minutes_of_rows_a_day():
    family = discover()["thermal_room"]                  # 60-s samples
    vehicles, _ = plan_fleet(family, 1, 0, 1, 1)
    plain = family.simulate(vehicles, START, 4)[vehicles[0].asset_id]
    frame = LoggedFamily(family, Logger(resend=1.0)).simulate(vehicles, START, 4)[
        vehicles[0].asset_id]
    back = np.flatnonzero(frame.index[1:] <= frame.index[:-1]) + 1
    assert len(back) == 4                                # one reconnect a day
    assert 4 * 10 <= len(frame) - len(plain) <= 4 * 61
    # the rows sent again are rows already sent, as stamped; once each, the plain log
    pd.testing.assert_frame_equal(frame[~frame.index.duplicated()], plain, check_freq=False)


def test_a_room_whose_gateway_resends_rows_every_day_is_baselined_and_scored(capsys):
    # before 2026-11-29 every such day was a failed read (duplicate or backward timestamps)
    cells = _report_row(capsys, ["thermal_room:resend=1", "--healthy-assets", "2",
                                 "--baseline-days", "3", "--nights", "2", "--faulty-per-cell", "0"])
    assert cells[2] == "0 / 0 / 0"        # no read, baseline or night failed
    assert cells[3].split(",")[0].endswith("/4")   # 2 vehicles x 2 nights scored


def test_a_room_whose_logger_drops_out_every_day_is_baselined_and_scored(capsys):
    # before 2026-11-29 every such day was a failed read (a "gap")
    cells = _report_row(capsys, ["thermal_room:outage=1,dropout=1", "--healthy-assets", "2",
                                 "--baseline-days", "3", "--nights", "2", "--faulty-per-cell", "0"])
    assert cells[2] == "0 / 0 / 0"        # no read, baseline or night failed
    assert cells[3].split(",")[0].endswith("/4")   # 2 vehicles x 2 nights scored


def _report_row(capsys, argv: list[str]) -> list[str]:
    """The cells of the report's row of ``argv[0]`` that ``main(argv)`` prints (it succeeds)."""
    assert main(argv) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith(f"| {argv[0]}"))
    return [c.strip() for c in line.split("|")[1:-1]]


def test_a_room_logged_every_5_minutes_is_baselined_and_scored(capsys):
    cells = _report_row(capsys, ["thermal_room:every=5", "--healthy-assets", "2",
                                 "--baseline-days", "3", "--nights", "2", "--faulty-per-cell", "0"])
    assert cells[1] == "[300.0]"          # the analysis interval: the logger's
    assert cells[2] == "0 / 0 / 0"        # no read, baseline or night failed
    assert cells[3].split(",")[0].endswith("/4")   # 2 vehicles x 2 nights scored


def test_a_room_logged_every_15_minutes_is_baselined_with_the_defaults(capsys):
    # a day at 15 minutes holds 96 samples, fewer than the 200 a window asks for: the
    # baselines resolve min_samples = "auto" to 48 (tests/graybox/test_settings.py) instead
    # of failing every fit, and a large fault is still found
    cells = _report_row(capsys, ["thermal_room:every=15", "--healthy-assets", "4",
                                 "--baseline-days", "3", "--nights", "3", "--faulty-per-cell", "1"])
    assert cells[1] == "[900.0]"
    assert cells[2] == "0 / 0 / 0"        # no read, baseline or night failed
    assert cells[3].endswith("/12")       # 4 vehicles x 3 nights scored
    large_found, large = (int(x) for x in cells[5].split("/"))
    assert large == 4 and large_found >= 1
