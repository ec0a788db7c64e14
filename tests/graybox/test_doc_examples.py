"""The Python examples of docs/python-api.md and docs/models.md run as printed (the API
example on simulated telemetry)."""
import pathlib
import re

from graybox.simulation import demo_fleet, write_fleet

DOCS = pathlib.Path(__file__).resolve().parents[2] / "docs"
PYTHON_API, MODELS = DOCS / "python-api.md", DOCS / "models.md"


def test_python_api_example_runs(tmp_path, monkeypatch, capsys):
    text = PYTHON_API.read_text()
    section = text.split("# Python API", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    write_fleet(demo_fleet(n_vehicles=2, days=6), tmp_path / "telemetry")
    monkeypatch.chdir(tmp_path)
    exec(compile(code, str(PYTHON_API), "exec"), {})
    out = capsys.readouterr().out
    assert out.count("zeta=") == 4 and '"channels"' in out


def test_hidden_state_model_is_a_valid_white_box():
    import numpy as np

    section = MODELS.read_text().split("## Hidden states, an output map", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    namespace = {}
    exec(compile(code, str(MODELS), "exec"), namespace)
    pack = namespace["Pack"]({"ocv": {"breakpoints": [0.0, 0.5, 1.0],
                                      "values": [322.0, 371.0, 401.0]}},
                             {"voltage": "pack_voltage", "current": "pack_current"})
    assert pack.hidden_states == ("soc", "v1", "v2")
    assert pack.required_columns == ("pack_voltage", "temp", "pack_current", "ambient")
    x, u = np.array([[0.5, 0.0, 0.0, 25.0]]), np.array([[100.0, 20.0]])
    assert pack.output(x, u)[0, 0] == 371.0 - 0.06 * 100.0
    assert pack.derivatives(x, u).shape == (1, 4)


def test_tiers_by_hand_example_recovers_the_simulated_residual(capsys):
    import numpy as np

    section = PYTHON_API.read_text().split("## Using the tiers by hand", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    namespace = {}
    exec(compile(code, str(PYTHON_API), "exec"), namespace)
    # an integrated AR(2) with a1 = 0.6, a2 = -0.3: one difference, order 2, white noise left
    assert namespace["choice"].differencing.order == 1
    linear = namespace["linear"]
    assert linear.order == 2
    assert np.all(np.abs(np.subtract(linear.coefficients, (0.6, -0.3)))
                  < 3 * np.asarray(linear.standard_errors))
    assert namespace["noise"].is_white
    assert "Ljung-Box p=" in capsys.readouterr().out
