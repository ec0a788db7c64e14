"""The diagnosis benchmark's ``--evidence since-alarm`` experiment: which nights an alarmed
night's alert episode spans for a given alarm sequence, and that the default (``candidate``)
is the product's protocol, each night's candidate span."""
import pytest

from benchmarks.detection.grid import trailing_nights
from benchmarks.diagnosis.__main__ import grid_from_args, parse_args
from benchmarks.diagnosis.episode import alert_opened, diagnosed_nights
from benchmarks.diagnosis.grid_run import run_grid


def test_an_episode_opens_at_the_first_of_the_consecutive_alarmed_nights():
    assert alert_opened(8, {6, 7, 8}, 4) == 6
    assert alert_opened(8, {5, 7, 8}, 4) == 7          # night 6 did not alarm: a new alert
    assert alert_opened(8, {8}, 4) == 8
    assert alert_opened(5, {2, 3, 4, 5}, 4) == 4       # no candidate before the baseline's end


def test_the_episode_starts_at_the_opening_candidates_span_and_is_capped():
    # baseline's end 4, two-night candidates, alarms from the onset night 6 on
    alarms = {6, 7, 8, 9, 10}
    spans = {n: list(diagnosed_nights(n, alarms, 2, 4, "since-alarm", most=4))
             for n in range(6, 11)}
    assert spans == {6: [5, 6], 7: [5, 6, 7], 8: [5, 6, 7, 8], 9: [6, 7, 8, 9],
                     10: [7, 8, 9, 10]}
    # an alert that closed and opened again starts over
    assert list(diagnosed_nights(9, {6, 7, 9}, 2, 4, "since-alarm")) == [8, 9]
    # a night that did not alarm (a healthy night, diagnosed for the false-cause rate) reads
    # its candidate's span
    assert list(diagnosed_nights(8, {6, 7}, 2, 4, "since-alarm")) == [7, 8]
    # the first night with a candidate: its span holds it alone
    assert list(diagnosed_nights(4, {4}, 2, 4, "since-alarm")) == [4]
    assert list(diagnosed_nights(6, {4, 5, 6}, 2, 4, "since-alarm")) == [4, 5, 6]


def test_the_default_and_a_cap_of_a_candidates_nights_are_the_candidates_span():
    alarms = {5, 6, 7, 9}
    for night in range(4, 11):
        span = trailing_nights(night, 2, 4)
        assert diagnosed_nights(night, alarms, 2, 4) == span
        assert diagnosed_nights(night, alarms, 2, 4, "since-alarm", most=2) == span
        assert diagnosed_nights(night, alarms, 3, 4, "candidate") == trailing_nights(night, 3, 4)


def test_a_cap_below_a_candidates_nights_or_an_unknown_evidence_is_refused():
    with pytest.raises(ValueError, match="shorter"):
        diagnosed_nights(8, {8}, 2, 4, "since-alarm", most=1)
    with pytest.raises(ValueError, match="evidence"):
        diagnosed_nights(8, {8}, 2, 4, "episode")
    with pytest.raises(SystemExit):
        parse_args(["--evidence", "since-alarm", "--episode-nights", "1"])


TINY = ["--kinds", "bias", "--sizes", "large", "--model-errors", "0", "--vehicles", "1",
        "--pre-nights", "1", "--post-nights", "2"]


@pytest.fixture(scope="module")
def runs():
    return {evidence: run_grid(grid_from_args(parse_args(TINY + ["--evidence", evidence])))
            for evidence in ("candidate", "since-alarm")}


def _answer(row):
    return {k: row.get(k) for k in ("alarm", "explained", "first", "first_estimate",
                                    "first_score", "expected_rank", "top")}


def test_the_default_diagnoses_the_candidates_nights_and_says_nothing_of_an_episode(runs):
    default = runs["candidate"]
    assert default["grid"]["evidence"] == "candidate"
    assert all("diagnosed_nights" not in r for r in default["rows"])
    bias = [r for r in default["rows"] if r["fault"] == "bias"]
    assert [r["night"] for r in bias] == [5, 6] and all(r["alarm"] for r in bias)


def test_since_alarm_reads_the_episode_and_keeps_the_onset_nights_answer(runs):
    default, episode = ({(r["fault"], r["night"]): r for r in runs[e]["rows"]}
                        for e in ("candidate", "since-alarm"))
    # the onset night (5) opens the alert: its episode is its candidate's span, same answer
    assert episode["bias", 5]["diagnosed_nights"] == [4, 5]
    assert _answer(episode["bias", 5]) == _answer(default["bias", 5])
    # the next night reads the three nights since the alert's candidate span began
    assert episode["bias", 6]["diagnosed_nights"] == [4, 6]
    assert episode["bias", 6]["first"] == "omega sensor bias"
    assert episode["bias", 6]["first_estimate"] == pytest.approx(2.0, abs=0.2)
    # a healthy night that did not alarm reads its candidate's span, as by default
    for night in (4, 5, 6):
        healthy = episode["healthy", night]
        if not healthy["alarm"]:
            assert _answer(healthy) == _answer(default["healthy", night])


def test_by_night_splits_the_onset_night_from_the_later_ones(runs):
    from benchmarks.diagnosis.by_night import night_by_night, split, table

    record = {"grid": runs["since-alarm"]}
    cells = split(record)[("bias", 2.0, 0.0)]
    assert (cells["all"]["detected"], cells["onset"]["detected"], cells["later"]["detected"]) \
        == (2, 1, 1)
    assert cells[1]["top1"] == cells[2]["top1"] == 1
    lines = table([record, {"grid": runs["candidate"]}], ["since-alarm", "candidate"])
    assert lines[2].startswith("| bias | 2 | 0% | 2/2 (100%) / 1/1 (100%) / 1/1 (100%) |")
    assert night_by_night([record], ["since-alarm"])[2] == (
        "| bias | 2 | 0% | since-alarm | 1/1 (100%) | 1/1 (100%) |")


def test_the_gap_is_the_expected_hypothesis_lead_over_its_best_rival():
    from benchmarks.diagnosis.by_night import gap

    top = [{"hypothesis": "parameter compressor_linear", "score": 9.0},
           {"hypothesis": "omega sensor bias", "score": 7.5},
           {"hypothesis": "parameter turbine_gain", "score": 3.0}]
    assert gap({"expected": "bias omega", "top": top}) == -1.5
    assert gap({"expected": "bias omega", "top": top[1:]}) == 4.5
    assert gap({"expected": "parameter inertia", "top": top}) != gap(
        {"expected": "parameter inertia", "top": top})   # not among the kept five: NaN
