"""What every command's start imports: not scipy.stats and scipy.signal (about 0.5 s of CPU),
which only a simulation (``fleet-health demo``) or the inverse residual needs."""
import subprocess
import sys


def test_the_command_line_and_the_nightly_flow_do_not_import_scipy_stats_or_signal():
    code = ("import sys, flows.cli, flows.nightly, flows.commands.run, graybox.simulation; "
            "print(sorted(m for m in sys.modules if m.startswith(('scipy.stats', "
            "'scipy.signal'))))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert done.stdout.strip() == "[]"
