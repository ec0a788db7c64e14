"""What every command's start imports: not scipy.stats and scipy.signal (about 0.5 s of CPU),
which only a simulation (``fleet-health demo``) or the inverse residual needs."""
from fresh_imports import loaded_after


def test_the_command_line_and_the_nightly_flow_do_not_import_scipy_stats_or_signal():
    loaded = loaded_after("flows.cli, flows.nightly, flows.commands.run, graybox.simulation",
                          ("scipy.stats", "scipy.signal"))
    assert loaded == "[]"
