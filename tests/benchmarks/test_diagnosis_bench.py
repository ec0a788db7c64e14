"""The diagnosis benchmark on a tiny configuration: one vehicle, a sensor bias of 2 rad/s,
the exact white box, one night from the onset. The night alarms, the diagnosis ranks the
speed sensor's bias first with about the injected size, and the scores and the markdown
section say so."""
import re

import pytest

from benchmarks.diagnosis import scores
from benchmarks.diagnosis.__main__ import grid_from_args, parse_args
from benchmarks.diagnosis.expected import implied_magnitude
from benchmarks.diagnosis.grid_run import run_grid
from benchmarks.diagnosis.report import render


@pytest.fixture(scope="module")
def result():
    args = parse_args(["--kinds", "bias", "--sizes", "large", "--model-errors", "0",
                       "--vehicles", "1", "--pre-nights", "0", "--post-nights", "1"])
    return run_grid(grid_from_args(args))


def test_the_bias_night_alarms_and_its_first_hypothesis_is_the_speed_sensor_bias(result):
    faulty = [r for r in result["rows"] if r["fault"] == "bias"]
    assert len(faulty) == 1
    night = faulty[0]
    assert night["magnitude"] == 2.0 and night["size"] == "large"
    assert night["alarm"] and night["explained"]
    assert night["first"] == "omega sensor bias" and night["expected_rank"] == 1
    assert night["implied_magnitude"] == pytest.approx(2.0, abs=0.2)
    low, high = night["expected_interval"]
    assert low < night["expected_estimate"] < high


def test_the_scores_count_it_as_a_top_one_hit(result):
    cell, = scores.accuracy(result["rows"])
    assert (cell["fault"], cell["detected"], cell["top1"], cell["top3"]) == ("bias", 1, 1, 1)
    confusion = scores.confusion(result["rows"])
    assert confusion[0.0]["bias"] == {"omega sensor bias": 1}
    section = render(result, "python -m benchmarks.diagnosis ...", 1.0, ("load", "load"))
    assert ("| bias | 2 (large) | 0% | 1 | 1 | bias omega | 1/1 (100%) | 1/1 (100%) | 1/1 (100%) |"
            in section)


def test_the_implied_magnitudes_invert_the_expected_hypotheses():
    assert implied_magnitude("friction", 50 / 1.2, 50.0) == pytest.approx(0.2)
    assert implied_magnitude("bias", 0.5, 0.0) == 0.5
    # the innovations' spread, of which the sensor's noise is a share: a lower bound
    assert implied_magnitude("noise", 1.13, 1.0) == pytest.approx(0.13)
    assert implied_magnitude("nonlinear", 1.0, 1.0) != implied_magnitude("nonlinear", 1.0, 1.0)


def test_a_noise_fault_counts_only_when_its_noise_level_rose():
    def night(estimate, explained=True):
        top = [{"hypothesis": "omega noise level", "estimate": estimate, "score": 50.0},
               {"hypothesis": "parameter inertia", "estimate": 40.0, "score": 10.0}]
        return {"fault": "noise", "magnitude": 0.3, "size": "large", "model_error": 0.2,
                "alarm": True, "diagnosed": True, "explained": explained,
                "expected": "noise omega", "expected_rank": 1, "expected_score": 50.0,
                "expected_estimate": estimate, "first": "omega noise level",
                "first_kind": "noise", "first_estimate": estimate, "top": top}
    rows = [night(1.3), night(0.8), night(1.2, explained=False)]
    cell, = scores.accuracy(rows)
    assert (cell["detected"], cell["top1"], cell["top3"], cell["no_cause"]) == (3, 1, 2, 1)
    # with a fall not a cause, the 0.8 night's first answer is inertia
    assert cell["top1_noise_rise_only"] == 2
    assert scores.first_if_noise_only_rises(rows[1]) == "parameter inertia"
    assert scores.confusion(rows)[0.2]["noise"] == {"omega noise level up": 1,
                                                    "omega noise level down": 1,
                                                    "no single cause": 1}


def test_the_command_writes_the_section_and_a_record_it_renders_again(tmp_path):
    import json

    from benchmarks.diagnosis.__main__ import main
    out, record = tmp_path / "diagnosis.md", tmp_path / "diagnosis.json"
    assert main(["--kinds", "bias", "--sizes", "large", "--model-errors", "0", "--vehicles", "1",
                 "--pre-nights", "0", "--post-nights", "1", "--out", str(out),
                 "--json", str(record)]) == 0
    section = out.read_text()
    assert "| bias | 2 (large) | 0% | 1 | 1 | bias omega | 1/1 (100%) |" in section
    load = r"`\d\d:\d\d:\d\d load average: \d+\.\d\d, \d+\.\d\d, \d+\.\d\d`"
    assert re.search(f"load before: {load}; after: {load}\\.", section)
    data = json.loads(record.read_text())
    assert [r["first"] for r in data["grid"]["rows"] if r["fault"] == "bias"] == ["omega sensor bias"]
    again = tmp_path / "again.md"
    assert main(["--rerender", str(record), "--out", str(again)]) == 0
    assert again.read_text() == section


def test_the_cost_benchmark_times_one_night_of_a_small_family():
    from benchmarks.diagnosis.cost import measure

    row = measure("thermal_room")
    assert (row["states"], row["hidden"], row["hypotheses"], row["samples"]) == (2, 0, 11, 1440)
    assert 0 < row["seconds"] < 60 and row["summary"]


def test_the_cost_benchmark_diagnoses_a_candidates_two_nights():
    from benchmarks.diagnosis.cost import measure

    row = measure("thermal_room", nights=2)
    assert row["nights"] == 2 and row["samples"] == 1440 and row["summary"]
