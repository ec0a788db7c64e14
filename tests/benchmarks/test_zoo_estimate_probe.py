"""The estimate probe's statistic: each hypothesis' estimate against the healthy nights'."""
import pytest

from benchmarks.zoo.estimate_probe import largest_z, summary


def night(vehicle, fault="", size="", **estimates):
    return {"vehicle": vehicle, "fault": fault, "size": size, "alarm": bool(fault),
            "max_ratio": 2.0 if fault else 0.1, "estimates": estimates}


def test_largest_z_is_the_farthest_hypothesis_in_healthy_spreads():
    pool = [night("A", a=1.0, b=10.0), night("A", a=2.0, b=20.0), night("A", a=3.0, b=30.0)]
    # a: (5 - 2) / 1 = 3; b: (25 - 20) / 10 = 0.5
    assert largest_z(night("A", a=5.0, b=25.0), pool) == (pytest.approx(3.0), "a")
    # a hypothesis with fewer than three finite healthy estimates, or none of its own, is skipped
    pool[0]["estimates"]["c"] = 1.0
    assert largest_z(night("A", a=2.0, b=20.0, c=100.0), pool) == (0.0, None)


def test_summary_compares_healthy_nights_leave_one_out_and_faults_against_all():
    healthy = [night("A", a=x) for x in (1.0, 2.0, 3.0, 4.0)]
    rows = healthy + [night("A", "leak", "large", a=12.0), night("A", "leak", "large", a=2.5)]
    result = summary(rows)
    assert result["healthy_nights"] == 4
    # the night at 1: its others 2, 3, 4 have mean 3 and sd 1
    assert result["healthy_z"]["max"] == pytest.approx(2.0)
    # the fault's largest night: (12 - 2.5) / sd(1, 2, 3, 4)
    fault = result["faults"]["leak/large"]
    assert fault["largest_z"] == pytest.approx(9.5 / 1.2909944, rel=1e-6)
    assert fault["hypothesis"] == "a" and fault["tiers_alarmed"]
