"""ProgPy models as white boxes: variables, parameters, dynamics against ProgPy's own, the
residual on ProgPy-simulated telemetry, and a worn pump told apart from a healthy one."""
from __future__ import annotations

import pickle
import subprocess
import sys
import warnings

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("progpy")

import progpy  # noqa: E402
from progpy.models import BatteryCircuit, CentrifugalPump  # noqa: E402

import graybox as gb  # noqa: E402
from graybox.analysis_rate import fastest_rate  # noqa: E402
from graybox.exceptions import ModelSpecError  # noqa: E402
from graybox.models import ModelSpec, load_model  # noqa: E402
from graybox.models.progpy import ProgPyModel  # noqa: E402
from graybox.models.progpy_simulation import (pump_cycle_load, pump_stops,  # noqa: E402
                                              simulate_progpy_fleet, stopped_load)
from graybox.integration import Integration  # noqa: E402
from graybox.residual import one_step_residual, residual_frame  # noqa: E402
from graybox.state_estimation import estimate_states, window_arrays  # noqa: E402
from graybox.telemetry.writing import write_telemetry  # noqa: E402

PUMP = "graybox.models.progpy:CentrifugalPump"
START = pd.Timestamp("2026-01-01", tz="UTC")
V0 = 471.2389
#: BatteryCircuit's full charge (its initial qb), coulombs
FULL_CHARGE = 7856.3254


#: near the pump's operating point, so that the telemetry starts warm
WARM = {"w": 385.0, "Q": 0.117, "Tt": 336.0, "Tr": 329.0, "To": 318.0}
PROCESS_NOISE = {"w": 0.5, "Q": 1e-4, "Tt": 0.01, "Tr": 0.01, "To": 0.001}
MEASUREMENT_NOISE = {"w": 0.05, "Qout": 1e-5, "Tt": 0.01, "Tr": 0.01, "To": 0.01}


def pump(**parameters):
    return load_model(PUMP, parameters, {"Q": "Qout"})


def operating_points(n=6, seed=0):
    rng = np.random.default_rng(seed)
    x = np.column_stack([rng.uniform(360, 400, n), rng.uniform(0.08, 0.13, n),
                         rng.uniform(300, 340, n), rng.uniform(300, 335, n),
                         rng.uniform(295, 320, n)])
    voltage = rng.uniform(460, 520, n)
    u = np.column_stack([np.full(n, 290.0), voltage, np.full(n, 928654.0),
                         np.full(n, 239179.0), 0.8 * voltage])
    return x, u


def progpy_pump():
    """ProgPy's own pump (its construction warns that the wear rates are states)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return CentrifugalPump()


def progpy_rates(model, x, u, **state):
    """The rates ProgPy's own pump gives, one sample at a time: (next_state(dt) - x) / dt."""
    dt = 1e-3
    rates = []
    for row, load in zip(x, u):
        full = dict(model.parameters["x0"], QLeak=0.0, **state)
        full.update(zip(("w", "Q", "Tt", "Tr", "To"), row))
        xs = model.StateContainer(full)
        us = model.InputContainer(dict(zip(model.inputs, load)))
        following = model.next_state(xs, us, dt)
        rates.append([(following[s] - xs[s]) / dt for s in ("w", "Q", "Tt", "Tr", "To")])
    return np.array(rates)


# -- variables and parameters -----------------------------------------------------------------

def test_catalogue_pump_variables_and_columns():
    model = pump()
    assert isinstance(model, ProgPyModel) and type(model).spec() == PUMP
    # outputs named like states are observed; Q is observed because the column map names it
    assert model.states == ("w", "Q", "Tt", "Tr", "To")
    assert model.inputs == ("Tamb", "V", "pdisch", "psuc", "wsync")
    assert model.required_columns == ("w", "Qout", "Tt", "Tr", "To",
                                      "Tamb", "V", "pdisch", "psuc", "wsync")
    assert model.is_discrete
    p = model.parameters
    assert p["I"] == 50.0 and p["FluidI"] == 5.0 and p["x0_A"] == 12.7084
    assert p["x0_wA"] == 0.0 and p["derivative_step"] == 1e-3
    # wear rates are states of this pump (held at x0_w*), not parameters; noise is not one
    assert {"wA", "wRadial", "wThrust", "A", "process_noise", "x0"}.isdisjoint(p)
    # wear (constant) and the leak flow (set afresh each step: algebraic) are held
    assert type(model).held == ("A", "rRadial", "rThrust", "QLeak", "wA", "wRadial", "wThrust")
    assert model.hidden_states == ()
    # without the map, the flow Q is hidden and ProgPy's output Qout = Q - QLeak predicted
    without_flow = load_model(PUMP)
    assert without_flow.states == ("w", "Q", "Tt", "Tr", "To")
    assert without_flow.outputs == ("w", "Tt", "Tr", "To", "Qout")
    assert without_flow.hidden_states == ("Q",) and without_flow.initial_state == {"Q": 0.0}


def test_model_spec_round_trip_rebuilds_the_same_white_box():
    model = pump(I=60.0, x0_A=12.0)
    record = ModelSpec.from_model(model)
    again = ModelSpec.from_dict(record.to_dict()).load()
    assert type(again) is type(model)
    assert again.states == model.states and again.columns == model.columns
    assert again.parameters == model.parameters
    assert again.progpy.parameters["I"] == 60.0
    x, u = operating_points()
    np.testing.assert_array_equal(again.derivatives(x, u), model.derivatives(x, u))


@pytest.mark.filterwarnings("ignore:wA, wRadial, and wThrust:UserWarning")
def test_catalogue_model_pickles_by_reference():
    """A worker process (Dask, Prefect) gets the same class back, with its overrides."""
    model = pump(I=60.0)
    again = pickle.loads(pickle.dumps(model))
    assert type(again) is type(model) and again.progpy.parameters["I"] == 60.0
    x, u = operating_points()
    np.testing.assert_array_equal(again.derivatives(x, u), model.derivatives(x, u))


def test_derived_parameters_are_not_overridable():
    thrown = load_model("graybox.models.progpy:ThrownObject", columns={"v": "v"})
    assert "lumped_param" not in thrown.parameters and "m" in thrown.parameters


@pytest.mark.parametrize("spec, parameters, columns, message", [
    (PUMP, {"nonsense": 1.0}, {}, "unknown parameter 'nonsense'"),
    (PUMP, {"wA": 0.01}, {}, "'wA' is a ProgPy state .* parameter 'x0_wA'"),
    (PUMP, {}, {"flow": "Qout"}, "not ProgPy states, outputs or inputs"),
    (PUMP, {"derivative_step": 0.0}, {}, "derivative_step must be > 0"),
    ("graybox.models.progpy:NoSuchModel", {}, {}, "has no 'NoSuchModel'"),
])
def test_bad_specs_are_clear_errors(spec, parameters, columns, message):
    with pytest.raises(ModelSpecError, match=message):
        load_model(spec, parameters, columns)


def test_a_subclass_must_name_a_prognostics_model():
    with pytest.raises(ModelSpecError, match="not a progpy.PrognosticsModel"):
        class NotAModel(ProgPyModel):
            progpy_model = "graybox.models.gas_turbine:GasTurbineShaft"
    with pytest.raises(ModelSpecError, match="must name a ProgPy model"):
        class Unnamed(ProgPyModel):
            pass


def test_a_subclass_wraps_any_progpy_model():
    class Battery(ProgPyModel):
        progpy_model = "progpy.models:BatteryCircuit"

    model = Battery(columns={"v": "voltage"})
    # every state moves: all hidden, the temperature and voltage predicted by ProgPy's output
    assert type(model).held == () and model.hidden_states == ("tb", "qb", "qcp", "qcs")
    assert model.outputs == ("t", "v") and model.required_columns == ("t", "voltage", "i")
    assert model.initial_state == {"tb": 292.1, "qb": 7856.3254, "qcp": 0.0, "qcs": 0.0}
    assert not model.is_discrete

    class Charge(ProgPyModel):
        progpy_model = "progpy.models:BatteryCircuit"
        held = ("tb",)

    assert Charge(columns={}).hidden_states == ("qb", "qcp", "qcs")
    with pytest.raises(ModelSpecError, match=r"held names \['Tb'\]"):
        class Misspelt(ProgPyModel):
            progpy_model = "progpy.models:BatteryCircuit"
            held = ("Tb",)


class Drifter(progpy.PrognosticsModel):
    """A ProgPy model without outputs."""

    states, inputs, outputs = ["a"], [], []
    default_parameters = {"x0": {"a": 0.0}}

    def dx(self, x, u):
        return self.StateContainer({"a": np.ones_like(x["a"])})

    def output(self, x):
        return self.OutputContainer({})


def test_a_model_without_outputs_or_mapped_states_is_a_clear_error():
    class Wrapped(ProgPyModel):
        progpy_model = f"{__name__}:Drifter"

    with pytest.raises(ModelSpecError, match="predicts no telemetry channel"):
        Wrapped()
    assert Wrapped(columns={"a": "drift"}).required_columns == ("drift",)


def test_progpy_is_imported_only_when_a_model_is_used():
    code = ("import sys, graybox, graybox.models.progpy; "
            "assert 'progpy' not in sys.modules, 'imported early'; "
            "graybox.models.load_model('graybox.models.progpy:ThrownObject'); "
            "assert 'progpy' in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


# -- dynamics ---------------------------------------------------------------------------------

def test_discrete_pump_rates_are_progpys_next_state():
    model = pump()
    x, u = operating_points()
    expected = progpy_rates(progpy_pump(), x, u)
    np.testing.assert_allclose(model.derivatives(x, u), expected, rtol=1e-9, atol=1e-12)
    # the shaft equation by hand at one point: I dw/dt = Te - friction - back torque
    p = progpy_pump().parameters
    w, q, voltage, wsync = x[0, 0], x[0, 1], u[0, 1], u[0, 4]
    slip = (wsync - w) / wsync
    torque = (p["n"] * p["p"] * p["R2"] / (slip * (wsync + 1e-5)) * voltage ** 2
              / ((p["R1"] + p["R2"] / slip) ** 2 + (wsync * p["L1"]) ** 2))
    friction = (p["r"] + 1.4e-6 + 1.8e-6) * w
    back = -p["a2"] * q ** 2 + p["a1"] * w * q + p["a0"] * w ** 2
    assert model.derivatives(x[:1], u[:1])[0, 0] == pytest.approx(
        (torque - friction - back) / p["I"], rel=1e-9)


def test_a_batch_varies_the_inputs_progpy_takes_varying_and_is_cut_by_the_others():
    """ProgPy's pump builds its leak flow as a list of one number per sample: a batch in which
    its pressures varied would make that a T x T matrix. Its voltage and synchronous speed
    may vary within a batch. The rates are ProgPy's one sample at a time either way, from
    one ProgPy call per distinct pair of pressures (not per distinct row of inputs)."""
    model = pump()
    x, u = operating_points(8)
    u[4:, 2] += 1e5                                    # a second discharge pressure
    expected = progpy_rates(progpy_pump(), x, u)
    np.testing.assert_allclose(model.derivatives(x, u), expected, rtol=1e-9, atol=1e-12)
    # which inputs a batch may vary in, probed on that first batch: the voltage and the
    # synchronous speed; the pressures not; the ambient did not vary, so it was not probed
    assert model._free_inputs.tolist() == [False, True, False, False, True]
    calls = []
    original = model._progpy_rates
    model._progpy_rates = lambda full, inputs: calls.append(full.shape[1]) or original(full, inputs)
    np.testing.assert_allclose(model.derivatives(x, u), expected, rtol=1e-9, atol=1e-12)
    assert calls == [4, 4]
    # the same samples one pressure pair only: one call for all eight
    calls.clear()
    u[4:, 2] -= 1e5
    np.testing.assert_allclose(model.derivatives(x, u), progpy_rates(progpy_pump(), x, u),
                               rtol=1e-9, atol=1e-12)
    assert calls == [8]


def test_overrides_reach_the_dynamics():
    x, u = operating_points()
    base, heavy = pump().derivatives(x, u), pump(I=100.0).derivatives(x, u)
    np.testing.assert_allclose(heavy[:, 0], base[:, 0] / 2, rtol=1e-9)   # dw/dt = .../I
    np.testing.assert_array_equal(heavy[:, 1:], base[:, 1:])
    worn = pump(x0_A=11.0).derivatives(x, u)
    expected = progpy_rates(progpy_pump(), x, u, A=11.0)
    np.testing.assert_allclose(worn, expected, rtol=1e-9, atol=1e-12)
    assert np.all(worn[:, 1] < base[:, 1])   # a smaller impeller delivers less flow


def test_continuous_model_rates_are_progpys_dx():
    model = load_model("graybox.models.progpy:BatteryCircuit")
    x = np.array([[292.1, 7856.0, 0.0, 0.0], [300.0, 7000.0, 3.0, 1.0]])
    u = np.array([[2.0], [3.5]])
    battery = BatteryCircuit()
    outputs = model.output(x, u)
    for row, current, rates, y in zip(x, u, model.derivatives(x, u), outputs):
        state = battery.StateContainer(dict(zip(("tb", "qb", "qcp", "qcs"), row)))
        dx = battery.dx(state, battery.InputContainer({"i": current[0]}))
        assert rates == pytest.approx([dx[s] for s in ("tb", "qb", "qcp", "qcs")], rel=1e-12)
        z = battery.output(state)
        assert y == pytest.approx([z["t"], z["v"]], rel=1e-12)
    thrown = load_model("graybox.models.progpy:LinearThrownObject", columns={"v": "v"})
    np.testing.assert_allclose(thrown.derivatives(np.array([[10.0, 3.0]]), np.zeros((1, 0))),
                               [[3.0, -9.81]])


def test_pump_fastest_rate_is_its_shaft():
    """The analysis interval's linearisation works through the wrapper. At ProgPy's default
    operating point (V = 471.2 V, steady state of its simulation) the pump's modes are
    0.932 (shaft), 0.159 (flow) and < 0.01 1/s (temperatures): the shaft is the fastest."""
    x = [370.78, 0.1104, 302.6, 303.0, 292.3]
    u = [290.0, V0, 928654.0, 239179.0, 0.8 * V0]
    frame = pd.DataFrame([x + u], columns=list(pump().required_columns))
    assert fastest_rate(pump(), [frame]) == pytest.approx(0.93, abs=0.02)


# -- telemetry simulated by ProgPy ------------------------------------------------------------

def test_pump_cycle_load_follows_the_duty_cycle():
    volts = [pump_cycle_load(t)["V"] for t in (0, 799, 850, 900, 1699, 1750, 1800, 2650)]
    np.testing.assert_allclose(volts, [V0, V0, V0 + 20, V0 + 40, V0 + 40, V0 + 20, V0, V0 + 20])
    assert pump_cycle_load(850)["wsync"] == pytest.approx(0.8 * (V0 + 20))


def test_simulation_is_seeded_and_leaves_numpy_alone():
    model = pump()
    np.random.seed(123)
    expected_next = np.random.random()
    np.random.seed(123)
    first = simulate_progpy_fleet(model, ["P-1", "P-2"], START, 60.0, pump_cycle_load,
                                  process_noise=PROCESS_NOISE,
                                  measurement_noise=MEASUREMENT_NOISE, initial=WARM, seed=4)
    assert np.random.random() == expected_next
    again = simulate_progpy_fleet(model, ["P-1", "P-2"], START, 60.0, pump_cycle_load,
                                  process_noise=PROCESS_NOISE,
                                  measurement_noise=MEASUREMENT_NOISE, initial=WARM, seed=4)
    frame = first["P-1"]
    pd.testing.assert_frame_equal(frame, again["P-1"])
    assert list(frame.columns) == ["timestamp", "w", "Qout", "Tt", "Tr", "To",
                                   "Tamb", "V", "pdisch", "psuc", "wsync"]
    assert len(frame) == 61 and frame["timestamp"].iloc[-1] == START + pd.Timedelta(seconds=60)
    assert not np.allclose(frame["w"], first["P-2"]["w"])   # independent noise per asset


def test_noise_free_simulation_has_a_small_residual():
    """ProgPy's own (Euler, 0.05 s) trajectory through the white box's RK4 over 1 s: the
    one-step residual is a small fraction of the one-step change of every channel."""
    model = pump()
    late = lambda t: pump_cycle_load(t + 700)   # noqa: E731  (the up-ramp inside 300 s)
    frame = simulate_progpy_fleet(model, ["P-1"], START, 300.0, late, step=0.05,
                                  initial=WARM)["P-1"]
    x = frame[list(model.state_columns)].to_numpy()
    u = frame[list(model.input_columns)].to_numpy()
    residual = one_step_residual(model, x, u, 1.0)
    change = np.abs(np.diff(x, axis=0)).max(axis=0)
    assert np.all(np.abs(residual).max(axis=0) < 0.1 * change)


def test_state_change_takes_effect_at_its_time():
    model = pump()
    frames = simulate_progpy_fleet(model, ["P-1", "P-2"], START, 600.0, pump_cycle_load,
                                   initial=WARM, changes={"P-2": [(300.0, {"wA": 0.05})]})
    healthy, worn = frames["P-1"], frames["P-2"]
    np.testing.assert_allclose(worn["Qout"].iloc[:301], healthy["Qout"].iloc[:301])
    assert worn["Qout"].iloc[-1] < healthy["Qout"].iloc[-1] * 0.995   # the impeller wore
    with pytest.raises(ValueError, match="not a ProgPy state"):
        simulate_progpy_fleet(model, ["P-1"], START, 10.0, pump_cycle_load,
                              changes={"P-1": [(5.0, {"nonsense": 1.0})]})


def test_pump_stops_alternate_running_and_stopped_within_their_bounds():
    stops = pump_stops(40_000.0, seed=[1, 0], run=(1200.0, 2700.0), stop=(300.0, 900.0))
    assert stops == pump_stops(40_000.0, seed=[1, 0]) != pump_stops(40_000.0, seed=[1, 1])
    edges = [0.0] + [t for stop in stops for t in stop]
    running, stopped = np.diff(edges)[0::2], np.diff(edges)[1::2]
    assert len(stops) >= 10
    assert running.min() >= 1200 and running.max() <= 2700
    assert stopped[:-1].min() >= 300 and stopped.max() <= 900
    assert stops[-1][1] <= 40_000.0


def test_a_stopped_pump_spins_down_and_restarts_by_progpy_dynamics():
    model = pump()
    load = stopped_load(pump_cycle_load, [(100.0, 400.0)])
    assert [load(t)["V"] for t in (99.0, 100.0, 399.5, 400.0)] == [V0, 0.0, 0.0, V0]
    assert load(200.0)["wsync"] == pump_cycle_load(200.0)["wsync"]   # ProgPy's slip stays finite
    frames = simulate_progpy_fleet(model, ["P-1", "P-2", "P-3"], START, 700.0,
                                   {"P-1": pump_cycle_load, "P-2": load, "P-3": pump_cycle_load},
                                   initial=WARM)
    alone = simulate_progpy_fleet(model, ["P-1"], START, 700.0, pump_cycle_load, initial=WARM)
    pd.testing.assert_frame_equal(frames["P-1"], alone["P-1"])   # the first group as before
    running, stopped = frames["P-1"], frames["P-2"]
    # a row holds the input of the integration step that ended at it
    assert (stopped["V"].iloc[101:401] == 0).all() and (stopped["V"].iloc[[100, 401]] > 0).all()
    w = stopped["w"].to_numpy()
    assert w[400] < 0.5 * w[100]                         # spun down without torque
    assert np.all(np.diff(w[105:400]) < 0)
    assert w[700] == pytest.approx(running["w"].iloc[700], rel=0.01)   # restarted
    with pytest.raises(ValueError, match=r"no load for the simulated assets \['P-2'\]"):
        simulate_progpy_fleet(model, ["P-1", "P-2"], START, 10.0, {"P-1": pump_cycle_load})


@pytest.mark.slow
def test_worn_impeller_alarms_only_after_the_wear_starts(tmp_path):
    """Telemetry from ProgPy's pump with its own noise in half-hour windows: a baseline of
    three healthy windows; the fourth is still healthy (no alarm), then the impeller wears
    at ProgPy's example rate (wA = 0.01): the flow channel alarms, the others do not."""
    model = pump()
    window = 1800.0
    frames = simulate_progpy_fleet(model, ["P-1"], START, 5 * window, pump_cycle_load,
                                   process_noise=PROCESS_NOISE,
                                   measurement_noise=MEASUREMENT_NOISE, initial=WARM,
                                   changes={"P-1": [(4 * window, {"wA": 0.01})]}, seed=3)
    write_telemetry(tmp_path, "P-1", frames["P-1"].iloc[:-1])
    telemetry = gb.read_window(tmp_path, "P-1", model.required_columns,
                               inputs=model.input_columns)
    windows = telemetry.split("30min")
    assert len(windows) == 5
    baseline = gb.GrayBox(model).fit(windows[:3])
    healthy, worn = ({(e.channel, e.tier) for e in baseline.drift(night).entries if e.exceeded}
                     for night in windows[3:])
    assert healthy == set()
    assert ("Q", "noise") in worn and {channel for channel, _ in worn} == {"Q"}


# -- hidden states by ProgPy's own dynamics -----------------------------------------------------

def test_battery_hidden_charge_runs_by_progpys_dynamics_and_the_residual_is_the_noise():
    """ProgPy's BatteryCircuit (every state hidden; temperature and voltage by its output
    map), simulated by ProgPy at 0.02-s steps with 2 mV of voltage-sensor noise: the white box
    estimates the start (the full charge ProgPy starts from), the charge falls by exactly the
    current drawn (Coulomb counting, not held), and the voltage residual is the injected noise
    differenced, to 1 % of it."""
    model = load_model("graybox.models.progpy:BatteryCircuit")
    load = lambda t: {"i": 1.0 + 0.8 * np.sin(2 * np.pi * t / 300.0)}   # noqa: E731
    noisy = simulate_progpy_fleet(model, ["B-1"], START, 600.0, load, step=0.02,
                                  measurement_noise={"t": 0.0, "v": 0.002}, seed=3)["B-1"]
    clean = simulate_progpy_fleet(model, ["B-1"], START, 600.0, load, step=0.02)["B-1"]
    noisy, clean = noisy.set_index("timestamp"), clean.set_index("timestamp")
    window = estimate_states(model, *window_arrays(model, noisy), 1.0, Integration())
    assert window.initial_hidden["qb"] == pytest.approx(FULL_CHARGE, rel=1e-3)
    charge = window.states[:, model.states.index("qb")]
    current = noisy["i"].to_numpy()
    drawn = np.sum((current[:-1] + current[1:]) / 2)
    assert charge[0] - charge[-1] == pytest.approx(drawn, rel=1e-3)
    residual = residual_frame(model, noisy, window=window)["v"]
    noise = (noisy["v"] - clean["v"]).diff().iloc[1:]
    assert noise.std() == pytest.approx(0.002 * np.sqrt(2), rel=0.1)
    assert (residual - noise).std() < 0.01 * noise.std()


def test_the_damage_states_held_values_are_the_diagnosis_parameters():
    from graybox.diagnosis import candidate_hypotheses
    from graybox.parameter_estimation import float_parameters

    # the pump's impeller area and bearing friction coefficients change its dynamics; its
    # wear rates (held, as the areas they wear are) and its leak flow (set afresh) do not
    pump = load_model("graybox.models.progpy:CentrifugalPump", columns={"Q": "Qout"})
    assert pump.diagnosable == ("x0_A", "x0_rRadial", "x0_rThrust")
    parameters = [t for k, t in candidate_hypotheses(pump) if k == "parameter"]
    assert parameters == list(pump.diagnosable)
    # a battery holds no state: every number parameter stays a hypothesis
    battery = load_model("graybox.models.progpy:BatteryCircuit")
    assert battery.diagnosable == ()
    assert ([t for k, t in candidate_hypotheses(battery) if k == "parameter"]
            == list(float_parameters(battery)))


def test_the_read_once_containers_read_what_progpys_do_and_follow_writes():
    from graybox.models.progpy import _read_once

    model = progpy.models.CentrifugalPump()
    matrix = np.arange(len(model.states) * 3, dtype=float).reshape(len(model.states), 3)
    plain, fast = model.StateContainer(matrix.copy()), _read_once(model.StateContainer)(
        matrix.copy())
    assert isinstance(fast, model.StateContainer)
    for key in model.states:
        np.testing.assert_array_equal(fast[key], plain[key])
    single = _read_once(model.StateContainer)(matrix[:, :1].copy())
    assert single["w"] == model.StateContainer(matrix[:, :1].copy())["w"]
    fast["w"] = np.array([7.0, 8.0, 9.0])               # a write is read back
    np.testing.assert_array_equal(fast["w"], [7.0, 8.0, 9.0])
    fast.matrix = fast.matrix + 1.0                     # and so is a new matrix
    np.testing.assert_array_equal(fast["w"], [8.0, 9.0, 10.0])
