"""benchmarks.zoo.fleets: a family's counts pooled over zoo runs, judged against issue 18's
targets (known answers: the Clopper-Pearson bound of 600 healthy asset-nights allows 5 alarms,
1.93 %; 6 are 1.00 % but bound at 2.16 %)."""
import json

import pytest

from benchmarks.zoo.fleets import main, markdown, pool


def run(seed: int, family: str, alarms: int, small: list, large: list, held_out=False,
        failed_reads=None, calm_nights=None) -> dict:
    """The fields of one family's result in a zoo run's JSON that the pooling reads."""
    result = {"family": family, "title": family.title(), "held_out": held_out, "seed": seed,
              "false_alarms": {"alarms": alarms, "asset_nights": 300},
              "detected_small": small, "detected_large": large,
              "failed_reads": failed_reads or {}, "failed_baselines": {}, "failed_nights": {}}
    if calm_nights is not None:            # runs written before the count was kept lack it
        result["calm_nights"] = calm_nights
    return result


def test_counts_are_summed_per_family_over_the_runs_and_judged():
    first = [run(1, "room", 2, [3, 10], [10, 10]), run(1, "mast", 3, [0, 10], [9, 10], True)]
    second = [run(2, "room", 3, [4, 10], [9, 10]), run(2, "mast", 3, [1, 10], [9, 10], True,
                                                        {"A day 5": "stuck"})]
    room, mast = pool([first, second])
    assert (room.family, room.seeds, room.alarms, room.asset_nights) == ("room", (1, 2), 5, 600)
    assert room.small == (7, 20) and room.large == (19, 20)
    assert room.false_alarms["interval"][1] == pytest.approx(0.0193, abs=1e-4)
    assert room.false_alarms_met and room.large_met               # 5/600; 19/20 = 95 %
    assert mast.alarms == 6 and mast.false_alarms["rate"] == pytest.approx(0.01)
    assert mast.false_alarms["interval"][1] == pytest.approx(0.0216, abs=1e-4)
    assert not mast.false_alarms_met and not mast.large_met       # bound 2.16 %; 18/20
    assert mast.failures == 1


def test_a_family_missing_from_a_run_is_pooled_over_the_others():
    (room,) = pool([[run(1, "room", 0, [1, 2], [2, 2])], []])
    assert room.seeds == (1,) and room.asset_nights == 300
    assert room.false_alarms["interval"][1] == pytest.approx(0.0122, abs=1e-4)
    assert room.false_alarms_met and room.large_met               # 0/300; 2/2


def test_the_table_and_the_command_line(tmp_path, capsys):
    runs = [[run(1, "room", 2, [3, 10], [10, 10]), run(1, "mast", 9, [0, 10], [2, 10], True)]]
    text = markdown(pool(runs))
    lines = text.splitlines()
    assert lines[2].startswith("| Room | tuning | 1 | 2/300 = 0.67 % (0.08-2.39 %) | NOT MET |")
    assert lines[3].startswith("| Mast | held out | 1 | 9/300 = 3.00 %")
    assert "- held out: healthy alarms 9/300, small faults 0/10 = 0 %, large 2/10 = 20 %" in text
    path = tmp_path / "run.json"
    path.write_text(json.dumps(runs[0]))
    assert main([str(path)]) == 0
    assert capsys.readouterr().out.strip() == text


def test_nights_too_short_to_fit_are_not_operating_not_failures():
    from benchmarks.zoo.run import night_not_operating
    from graybox.exceptions import InsufficientDataError, ShortWindowsError, TelemetryError

    assert night_not_operating(ShortWindowsError("window(s) [1] have 19 residual samples", (1,)))
    assert not night_not_operating(InsufficientDataError("no operating period"))
    assert not night_not_operating(TelemetryError("A", "stuck_channel", "a reading held 10 samples"))
    calm = {"T-1 night 0": "window(s) [0] have 19 residual samples",
            "T-2 night 3": "window(s) [1] have 12 residual samples"}
    (tyres,) = pool([[run(1, "tyres", 0, [1, 2], [2, 2], calm_nights=calm)],
                     [run(2, "tyres", 0, [1, 2], [2, 2])]])
    assert tyres.not_operating == 2 and tyres.failures == 0
    assert "| 0 | 2 |" in markdown([tyres])


def test_reads_of_a_machine_that_did_not_run_are_days_not_operating_not_failures():
    # what the product reports as not operating (an idle day, one that ran too little to
    # read) against a stuck sensor's read, a failure
    reads = {"W-1 day 2": "asset 'W-1': the machine did not run in [a, b) (grid running) "
                          "[no_data]",
             "W-1 day 6": "asset 'W-1': 1 sample(s) in the window: two are needed to infer "
                          "the sample interval [too_few_samples]",
             "W-2 day 7": "asset 'W-2', file f.parquet, row 58: channel 'p' stuck at 48.0 "
                          "for 11 consecutive samples [stuck_channel]"}
    calm = {"W-2 night 3": "window(s) [1] have 12 residual samples"}
    (turbine,) = pool([[run(1, "turbine", 0, [1, 2], [2, 2], True, reads, calm)]])
    assert (turbine.failures, turbine.not_operating) == (1, 3)
    text = markdown([turbine])
    assert "| failures | days not operating |" in text and "| 1 | 3 |" in text
