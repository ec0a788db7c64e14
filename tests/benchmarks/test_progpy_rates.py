"""benchmarks.progpy_rates: a smoke run (the pump's window of ramps in one ProgPy call)."""
import pytest

pytest.importorskip("progpy")

from benchmarks.progpy_rates import main  # noqa: E402


def test_a_short_window_of_ramps_is_one_progpy_call(capsys):
    assert main(["--seconds", "300", "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert "301 samples" in out and "1 ProgPy call(s)" in out, out
