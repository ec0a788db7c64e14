"""The README's Python API example runs as printed (on simulated telemetry)."""
import pathlib
import re

from graybox.simulator import demo_fleet, write_fleet

README = pathlib.Path(__file__).resolve().parents[2] / "README.md"


def test_readme_python_api_example_runs(tmp_path, monkeypatch, capsys):
    text = README.read_text()
    section = text.split("## Python API", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    write_fleet(demo_fleet(n_vehicles=2, days=6), tmp_path / "telemetry")
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "README.md", "exec"), {})
    out = capsys.readouterr().out
    assert out.count("zeta=") == 4 and '"channels"' in out
