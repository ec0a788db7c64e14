"""fleet.toml: loading, defaults, paths, and errors that name the key."""
from __future__ import annotations

import os
import pathlib

import pandas as pd
import pytest

from flows.config import ConfigError, load_config, render_config
from graybox.telemetry import GridPolicy

MINIMAL = '''
[classes.turbine]
model = "graybox.models:GasTurbineShaft"
assets = ["T-*"]
columns = { omega = "shaft_speed" }
'''


def write(tmp_path: pathlib.Path, text: str) -> pathlib.Path:
    path = tmp_path / "fleet.toml"
    path.write_text(text)
    return path


def test_minimal_file_gets_the_documented_defaults(tmp_path):
    config = load_config(write(tmp_path, MINIMAL))
    assert config.telemetry_root == (tmp_path / "telemetry").resolve()
    assert config.tracking_uri == f"sqlite:///{(tmp_path / 'mlflow.db').resolve()}"
    assert config.alerts.false_alarm_rate == 0.01
    assert config.alerts.jsonl == (tmp_path / "alerts.jsonl").resolve()
    assert (config.nightly.batch_size, config.nightly.window, config.nightly.plots) == \
        (64, "1D", "alarms")
    assert (config.schedule.cron, config.schedule.timezone) == ("30 2 * * *", "UTC")
    turbine = config.classes["turbine"]
    assert turbine.matches("T-001") and not turbine.matches("P-001")
    model = turbine.load_model()
    assert model.required_columns == ("shaft_speed", "fuel_rate")


def test_full_file(tmp_path):
    config = load_config(write(tmp_path, '''
[telemetry]
root = "data/telemetry"
[mlflow]
tracking_uri = "http://mlflow.example:5000"
[alerts]
false_alarm_rate = 0.001
jsonl = "out/alerts.jsonl"
major_ratio = 3.0
critical_ratio = 10.0
[nightly]
batch_size = 16
window = "6h"
plots = "none"
retries = 0
retry_delay_seconds = 5
[schedule]
cron = "0 3 * * 1-5"
timezone = "Europe/Berlin"
[notifications]
block = "slack-webhook/fleet"
[classes.turbine]
model = "graybox.models:GasTurbineShaft"
parameters = { inertia = 10.0 }
assets = ["T-*", "SPARE-1"]
columns = { omega = "shaft_speed" }
settings = { hidden_units = 4, ar_span = 100.0, network = { max_iter = 50 } }
grid = { sample_interval = 10.0, max_gap = "1min", stuck_after = { "*" = "20min", fuel_rate = 0 } }
[classes.drive]
model = "graybox.models:LangevinShaft"
assets = ["D-*"]
'''))
    assert config.tracking_uri == "http://mlflow.example:5000"
    assert config.telemetry_root == (tmp_path / "data" / "telemetry").resolve()
    assert list(config.classes) == ["turbine", "drive"]
    turbine = config.classes["turbine"]
    assert turbine.settings.hidden_units == 4 and turbine.settings.network.max_iter == 50
    assert turbine.settings.ar_span == 100.0
    assert turbine.grid.sample_interval == 10.0 and turbine.grid.max_gap == 60.0
    assert turbine.grid.stuck_limit("shaft_speed") == 1200.0
    assert turbine.grid.stuck_limit("fuel_rate") == 0.0
    assert turbine.grid.min_duration == 3600.0
    assert config.classes["drive"].grid == GridPolicy()
    assert turbine.explicit_assets() == ("SPARE-1",)
    assert turbine.load_model().parameters["inertia"] == 10.0
    assert config.nightly.window == "6h" and config.notifications.block == "slack-webhook/fleet"
    assert config.class_of("D-7").name == "drive" and config.class_of("X-1") is None


def test_not_operating_after_defaults_to_a_week_and_can_be_turned_off(tmp_path):
    """Issue 18: how long an asset may be ``not operating`` before it is ``dormant``."""
    alerts = load_config(write(tmp_path, MINIMAL)).alerts
    assert alerts.not_operating_after_delta == pd.Timedelta(days=7)
    for text, delta in (('"36h"', pd.Timedelta(hours=36)), ('"off"', None), ('"OFF"', None)):
        config = load_config(write(tmp_path, f"[alerts]\nnot_operating_after = {text}\n"
                                             + MINIMAL))
        assert config.alerts.not_operating_after_delta == delta, text
        assert config.alerts.stale_after_delta == pd.Timedelta(days=2)    # its own key
    rendered = load_config(write(tmp_path, render_config()))
    assert rendered.alerts.not_operating_after == "7D"


def test_a_class_may_set_its_own_not_operating_after(tmp_path):
    from flows.dormancy import dormancy_limit

    fleet = "[alerts]\nnot_operating_after = \"36h\"\n" + MINIMAL
    config = load_config(write(tmp_path, fleet))
    assert dormancy_limit(config, "turbine") == ("36h", "[alerts] not_operating_after")
    for own, limit in (('"30D"', "30D"), ('"off"', None), ('"alerts"', "36h")):
        config = load_config(write(tmp_path, fleet.replace(
            "assets = ", f"not_operating_after = {own}\nassets = ", 1)))
        key = ("[classes.turbine] not_operating_after" if own != '"alerts"'
               else "[alerts] not_operating_after")
        assert dormancy_limit(config, "turbine") == (limit, key), own
    with pytest.raises(ConfigError, match=r"classes\.turbine\.not_operating_after"):
        load_config(write(tmp_path, fleet.replace("assets = ", "not_operating_after = \"soon\"\n"
                                                              "assets = ", 1)))


@pytest.mark.parametrize("text, where", [
    (MINIMAL.replace('model = ', 'modle = '), "fleet.toml: classes.turbine.modle: unknown key"),
    (MINIMAL + 'settings = { max_ar_order = 10 }\n',
     "fleet.toml: classes.turbine.settings.max_ar_order: replaced by ar_span"),
    (MINIMAL + 'settings = { max_delay = 10 }\n',
     "fleet.toml: classes.turbine.settings.max_delay: replaced by delay_span"),
    (MINIMAL.replace('"graybox.models:GasTurbineShaft"', '"graybox.models:NoSuchModel"'),
     "fleet.toml: classes.turbine.model: "),
    (MINIMAL.replace('"graybox.models:GasTurbineShaft"', '"not a spec"'),
     "fleet.toml: classes.turbine.model: "),
    (MINIMAL.replace('assets = ["T-*"]', 'assets = []'), "fleet.toml: classes.turbine.assets: "),
    (MINIMAL.replace('assets = ["T-*"]', 'assets = ["../etc"]'),
     "fleet.toml: classes.turbine.assets[0]: "),
    (MINIMAL.replace('assets = ["T-*"]\n', ''), "fleet.toml: classes.turbine.assets: missing"),
    (MINIMAL.replace('model = "graybox.models:GasTurbineShaft"\n', ''),
     "fleet.toml: classes.turbine.model: missing"),
    (MINIMAL.replace('omega = "shaft_speed"', 'speed = "shaft_speed"'),
     "fleet.toml: classes.turbine.columns: "),
    (MINIMAL + 'parameters = { gama = 0.1 }\n', "fleet.toml: classes.turbine.parameters: "),
    (MINIMAL + 'parameters = { inertia = "big" }\n',
     "fleet.toml: classes.turbine.parameters.inertia: must be a finite number"),
    (MINIMAL + 'settings = { hiden_units = 3 }\n',
     "fleet.toml: classes.turbine.settings.hiden_units: unknown setting"),
    (MINIMAL + 'settings = { residual = "magic" }\n', "fleet.toml: classes.turbine.settings: "),
    (MINIMAL + 'settings = { network = { iters = 3 } }\n',
     "fleet.toml: classes.turbine.settings.network.iters: unknown setting"),
    (MINIMAL + 'grid = { max_gap = -1 }\n', "fleet.toml: classes.turbine.grid.max_gap: "),
    (MINIMAL + 'grid = { max_gap = "40" }\n',
     "fleet.toml: classes.turbine.grid.max_gap: max_gap '40' has no unit"),
    (MINIMAL + 'grid = { stuck_after = "ages" }\n',
     "fleet.toml: classes.turbine.grid.stuck_after: "),
    (MINIMAL + 'grid = { stuck_after = { omega = "x" } }\n',
     "fleet.toml: classes.turbine.grid.stuck_after: "),
    (MINIMAL + 'grid = { min_duration = "0s" }\n',
     "fleet.toml: classes.turbine.grid.min_duration: "),
    (MINIMAL + 'grid = { fill = 1 }\n', "fleet.toml: classes.turbine.grid.fill: unknown setting"),
    ("[alerts]\nfalse_alarm_rate = 1.5\n" + MINIMAL, "fleet.toml: alerts.false_alarm_rate: "),
    ("[alerts]\nfalse_alarm_rate = true\n" + MINIMAL, "fleet.toml: alerts.false_alarm_rate: "),
    ("[alerts]\nmajor_ratio = 9.0\n" + MINIMAL, "fleet.toml: alerts: need 1 <= major_ratio"),
    ("[alerts]\nnot_operating_after = \"7\"\n" + MINIMAL,
     "fleet.toml: alerts.not_operating_after: '7' is not a duration such as '7D', '36h' or "
     "\"off\""),
    ("[alerts]\nnot_operating_after = \"0D\"\n" + MINIMAL,
     "fleet.toml: alerts.not_operating_after: '0D' must be a positive duration"),
    ("[alerts]\nnot_operating_after = 7\n" + MINIMAL, "fleet.toml: alerts.not_operating_after: "),
    ("[nightly]\nbatch_size = 0\n" + MINIMAL, "fleet.toml: nightly.batch_size: "),
    ("[nightly]\nwindow = \"7h\"\n" + MINIMAL, "fleet.toml: nightly.window: "),
    ("[nightly]\nwindow = \"soon\"\n" + MINIMAL, "fleet.toml: nightly.window: "),
    ("[nightly]\nplots = \"some\"\n" + MINIMAL, "fleet.toml: nightly.plots: "),
    ("[schedule]\ncron = \"every night\"\n" + MINIMAL, "fleet.toml: schedule.cron: "),
    ("[schedule]\ncron = \"30 25 * * *\"\n" + MINIMAL,
     "fleet.toml: schedule.cron: '30 25 * * *': hour 25 is outside 0-23"),
    ("[schedule]\ncron = \"0 2 * 13 *\"\n" + MINIMAL,
     "fleet.toml: schedule.cron: '0 2 * 13 *': month 13 is outside 1-12"),
    ("[schedule]\ntimezone = \"Mars/Olympus\"\n" + MINIMAL, "fleet.toml: schedule.timezone: "),
    ("[mlflow]\ntracking_uri = \"mlflow.db\"\n" + MINIMAL, "fleet.toml: mlflow.tracking_uri: "),
    ("[notifications]\nblock = \"slack\"\n" + MINIMAL, "fleet.toml: notifications.block: "),
    ("[telemetry]\nroot = 3\n" + MINIMAL, "fleet.toml: telemetry.root: "),
    ("[telemtry]\nroot = \"x\"\n" + MINIMAL, "fleet.toml: telemtry: unknown key"),
    ("[telemetry]\nroot = \"x\"\n", "fleet.toml: classes: missing table"),
    ("classes = 3\n", "fleet.toml: classes: must be a table"),
    ("[classes.\"bad name\"]\nmodel = \"x:y\"\n", "fleet.toml: classes.bad name: "),
    ("[classes\n", "fleet.toml: not valid TOML"),
])
def test_errors_name_the_key(tmp_path, text, where):
    with pytest.raises(ConfigError) as error:
        load_config(write(tmp_path, text))
    message = str(error.value)
    assert where in message, message


@pytest.mark.parametrize("old, new, example", [
    ("max_fill = 3", "'max_gap'", 'grid = { max_gap = "40s" }'),
    ("stuck_samples = 60", "'stuck_after'", 'grid = { stuck_after = "10min" }'),
    ("min_samples = 500", "'min_duration'", 'grid = { min_duration = "1h" }'),
])
def test_old_sample_count_grid_keys_name_their_duration_replacement(tmp_path, old, new,
                                                                     example):
    with pytest.raises(ConfigError) as error:
        load_config(write(tmp_path, MINIMAL + f'grid = {{ max_gap = "1min", {old} }}\n'))
    message = str(error.value)
    key = old.split()[0]
    assert message.startswith(f"fleet.toml: classes.turbine.grid.{key}: "), message
    assert new in message and example in message, message


def test_grid_durations_as_strings_or_seconds(tmp_path):
    config = load_config(write(tmp_path, MINIMAL + 'grid = { sample_interval = "1s", '
                                                   'max_gap = 5, stuck_after = "2h", '
                                                   'min_duration = "90min" }\n'))
    assert config.classes["turbine"].grid == GridPolicy(
        sample_interval=1.0, max_gap=5.0, stuck_after=7200.0, min_duration=5400.0)


def test_a_class_names_the_white_box_parameters_its_baselines_tune(tmp_path):
    config = load_config(write(tmp_path, MINIMAL + 'estimate = ["turbine_gain", '
                                                   '"compressor_linear"]\n'))
    assert config.classes["turbine"].estimate == ("turbine_gain", "compressor_linear")
    assert load_config(write(tmp_path, MINIMAL)).classes["turbine"].estimate == ()
    with pytest.raises(ConfigError, match=r"classes\.turbine\.estimate\[1\]: 'gain' is not a "
                                          r"number parameter of graybox.models.gas_turbine:"
                                          r"GasTurbineShaft; they are: inertia, turbine_gain"):
        load_config(write(tmp_path, MINIMAL + 'estimate = ["inertia", "gain"]\n'))


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="no such configuration file"):
        load_config(tmp_path / "nope.toml")


def test_overlapping_classes_are_a_configuration_error(tmp_path):
    config = load_config(write(tmp_path, MINIMAL + '''
[classes.other]
model = "graybox.models:LangevinShaft"
assets = ["T-00*"]
'''))
    assert config.class_of("T-100").name == "turbine"
    with pytest.raises(ConfigError, match="matches more than one vehicle class"):
        config.class_of("T-001")


def test_rendered_config_loads(tmp_path):
    config = load_config(write(tmp_path, render_config()))
    assert config.classes["turbine"].assets == ("T-*",)
    assert config.nightly.plots == "alarms"
    assert config.classes["turbine"].grid == GridPolicy()
    assert 'grid = { max_gap = "4min", stuck_after = "10min", min_duration = "1h" }' \
        in render_config()


def test_rendered_config_shows_the_task_runner_and_a_dask_section_that_loads(tmp_path):
    text = render_config()
    assert 'task_runner = "sequential"' in text
    assert load_config(write(tmp_path, text)).nightly.task_runner == "sequential"
    # uncommenting the [dask] example (address or workers) gives a Dask configuration that loads
    dask_text = text.replace('task_runner = "sequential"', 'task_runner = "dask"')
    for choice, expected in ((("# address",), ("tcp://scheduler:8786", None, 1)),
                             (("# workers", "# threads_per_worker"), (None, 2, 1))):
        uncommented = "\n".join(
            line[2:] if line.startswith(("# [dask]",) + choice) else line
            for line in dask_text.splitlines())
        config = load_config(write(tmp_path, uncommented))
        assert config.nightly.task_runner == "dask"
        assert (config.dask.address, config.dask.workers, config.dask.threads_per_worker) \
            == expected


def test_rendered_grid_overrides_load_back(tmp_path):
    grid = {"sample_interval": 1.0, "max_gap": "5s",
            "stuck_after": {"*": "15min", "pdisch": "30min", "fuel rate": 0}}
    text = render_config(grid=grid)
    assert 'max_gap = "5s"' in text and 'pdisch = "30min"' in text
    config = load_config(write(tmp_path, text))
    assert config.classes["turbine"].grid == GridPolicy(**grid)


def test_tracking_uri_override(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = load_config(write(tmp_path, MINIMAL)).with_tracking_uri("sqlite:///other.db")
    assert config.tracking_uri == f"sqlite:///{(tmp_path / 'other.db').resolve()}"


def test_task_runner_and_dask_defaults_and_values(tmp_path):
    from flows.config import DaskSettings

    config = load_config(write(tmp_path, MINIMAL))
    assert config.nightly.task_runner == "sequential"
    assert config.dask == DaskSettings(address=None, workers=None, threads_per_worker=1)
    local = load_config(write(tmp_path, '[nightly]\ntask_runner = "dask"\n[dask]\nworkers = 3\n'
                                        'threads_per_worker = 2\n' + MINIMAL))
    assert local.nightly.task_runner == "dask"
    assert local.dask == DaskSettings(address=None, workers=3, threads_per_worker=2)
    remote = load_config(write(tmp_path, '[nightly]\ntask_runner = "dask"\n[dask]\n'
                                         'address = "tcp://scheduler.example:8786"\n' + MINIMAL))
    assert remote.dask.address == "tcp://scheduler.example:8786"


@pytest.mark.parametrize("text, where", [
    ('[nightly]\ntask_runner = "ray"\n', "fleet.toml: nightly.task_runner: must be one of "
                                         "sequential, dask, got 'ray'"),
    ("[nightly]\ntask_runner = 1\n", "fleet.toml: nightly.task_runner: must be a non-empty"),
    ("[dask]\nworkers = 0\n", "fleet.toml: dask.workers: must be an integer >= 1, got 0"),
    ('[dask]\nworkers = "4"\n', "fleet.toml: dask.workers: must be an integer >= 1"),
    ("[dask]\nthreads_per_worker = 0\n", "fleet.toml: dask.threads_per_worker: must be an "
                                         "integer >= 1"),
    ('[dask]\naddress = "scheduler:8786"\n', "fleet.toml: dask.address: 'scheduler:8786' is "
                                             "not a scheduler address"),
    ('[dask]\naddress = "tcp://s:8786"\nworkers = 2\n', "fleet.toml: dask.workers: a cluster "
                                                        "at dask.address has its own workers"),
    ('[dask]\naddress = "tcp://s:8786"\nthreads_per_worker = 2\n',
     "fleet.toml: dask.threads_per_worker: a cluster at dask.address"),
    ("[dask]\nworker = 2\n", "fleet.toml: dask.worker: unknown key"),
])
def test_task_runner_and_dask_errors_name_the_key(tmp_path, text, where):
    with pytest.raises(ConfigError) as error:
        load_config(write(tmp_path, text + MINIMAL))
    assert where in str(error.value), str(error.value)


def test_dask_runner_options_from_the_configuration(tmp_path):
    from flows.task_runner import DaskBatches, SequentialBatches, batch_runner, runner_options

    config = load_config(write(tmp_path, '[nightly]\ntask_runner = "dask"\n[dask]\nworkers = 3\n'
                                         + MINIMAL))
    assert isinstance(batch_runner(config), DaskBatches)
    assert isinstance(batch_runner(load_config(write(tmp_path, MINIMAL))), SequentialBatches)
    options = runner_options(config.dask)["cluster_kwargs"]
    assert (options["n_workers"], options["threads_per_worker"]) == (3, 1)
    # local workers import fleet-health from where this process did
    import flows
    source = str(pathlib.Path(flows.__file__).resolve().parents[1])
    assert options["env"]["PYTHONPATH"].split(os.pathsep)[0] == source
    remote = load_config(write(tmp_path, '[dask]\naddress = "tcp://s:8786"\n' + MINIMAL))
    assert runner_options(remote.dask) == {"address": "tcp://s:8786"}
