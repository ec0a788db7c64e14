"""An electric vehicle's battery pack at 1 Hz, logged around the clock: drives, parking, AC and
DC charging.

Sign convention: the pack current is positive while it *discharges* (driving, the 12-V DC/DC
converter) and negative while it charges (regenerative braking, AC and DC charging).

True plant: 96 cells in series, scaled to pack level (about 75 Ah, 290-400 V). The state of
charge ``s`` falls with the current and with a leakage the current sensor does not see
(``Q s' = -(I + I_leak)``, ``I_leak = 0`` when healthy). The terminal voltage is
``V = OCV(s, T) - v1 - v2 - R0(T, s) I`` with an open-circuit voltage given by its own smooth
formula (a Nernst-like steep knee at low charge, a gentle wiggle, an entropic 0.1 mV/K per
cell), an ohmic resistance that falls with temperature (``exp(-0.03 (T - 25))``) and rises at
low charge, and two RC pairs (time constants about 10 s and 300 s, their resistances with the
same temperature factor), integrated exactly over each second for the held current. One
lumped thermal node is heated by the losses of ``R0`` and both RC pairs (and a soft short's
``I_leak OCV``) and cooled toward ambient through a conductance that is small while parked,
larger while driving (air flow) and large while the coolant pump runs (during DC charging
always, while driving or AC charging above 33 C until 30 C). The day's schedule is drawn per
asset-day: commuting, errand or trip days with one to three drives (a drive-cycle-like speed
profile of accelerations, cruising, braking with regeneration and stops, turned into pack
current through road load, drivetrain efficiency, a regeneration limit, cabin climate load,
and the constant-power draw at the pack's own voltage), parking (a 15-W standby load), an
evening AC charge at 10-20 A up to the asset's charge limit with a taper (plugged in always or
only when the charge is low; immediately or on a 22:00 timer), and on trip days a DC fast
charge of 100-150 A tapering to 85 %. A low-charge power limit keeps ``s`` above 5 %, a
regeneration limit near full keeps it below 98 %. The ambient temperature follows the asset's
climate (2-26 C), the day's weather (+-4 C), a daily cycle and slow noise. Each day starts
from a state drawn at 18:00 the day before, simulated through the evening (drives, charging)
to midnight. Telemetry at 1 Hz: pack voltage (0.01 V, 0.05 V noise), pack current (0.05 A,
0.15 A noise and a per-asset offset of some 0.03 A), pack temperature (0.1 C), ambient
temperature.

The white box a user writes (:class:`BatteryWhiteBox`): the same circuit with a hidden state
of charge and RC voltages and the measured temperature; the open-circuit voltage an 11-point
table copied from a datasheet (10-20 mV per cell off, linear between breakpoints), a constant
``R0`` and RC pairs 10-20 % off, one constant cooling conductance, no temperature or charge
dependence of the resistance, no entropic term, the RC losses left out of the heating.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel
from graybox.models.table import Table

DT = 1.0
#: the simulation starts at 18:00 the day before
WARMUP = 6 * 3600
DAY = 86400
CELLS = 96
#: the cell's open-circuit voltage: a0 + a1 s + a2 s^2 + a3 s^3 - a4 exp(-s / 0.04)
#: + a5 sin(3 pi s), volts at 25 C
OCV_COEFFICIENTS = (3.483, 0.495, -0.067, 0.269, 0.482, 0.012)
#: entropic coefficient, volts per kelvin and cell
ENTROPIC = 1.0e-4
#: the vehicle: mass (kg), drag area (m^2), rolling resistance, drivetrain efficiency,
#: regeneration efficiency, motoring and regeneration limits (W)
MASS, DRAG_AREA, ROLLING, EFFICIENCY, REGEN = 1800.0, 0.65, 0.011, 0.88, 0.70
MOTORING_LIMIT, REGEN_LIMIT = 110e3, 50e3
STANDBY_W, CHARGING_AUX_W, DRIVING_AUX_W = 15.0, 150.0, 300.0   # W
PARK, DRIVE, AC, DC = 0, 1, 2, 3
#: DC fast charging tapers from ``DC_TARGET - DC_TAPER`` and stops at ``DC_TARGET``
DC_TARGET, DC_TAPER = 0.85, 0.35
AC_TAPER = 0.03


def open_circuit_voltage(soc, temp):
    """The true pack's open-circuit voltage (V) at state of charge ``soc`` and temperature
    ``temp`` (C)."""
    a0, a1, a2, a3, a4, a5 = OCV_COEFFICIENTS
    s = np.clip(soc, 0.0, 1.0)
    cell = (a0 + s * (a1 + s * (a2 + s * a3)) - a4 * np.exp(-s / 0.04)
            + a5 * np.sin(3 * np.pi * s) + ENTROPIC * (temp - 25.0))
    return CELLS * cell


#: a datasheet's curve of the pack (cell values x 96), 10-20 mV per cell above the true one
DATASHEET_OCV = Table((0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0),
                      (289.8, 337.7, 345.8, 350.0, 354.4, 359.8, 366.9, 375.2, 383.9, 392.8,
                       402.7))


class BatteryWhiteBox(WhiteBoxModel):
    """An equivalent-circuit pack: hidden state of charge ``soc`` (0-1) and RC voltages ``v1``,
    ``v2`` (V), measured temperature ``temp`` (C); outputs the terminal voltage and the
    temperature; inputs the pack current (A, positive discharging) and the ambient
    temperature (C). Capacity in A s, resistances in ohm, capacitances in F, heat capacity
    in J/K, cooling in W/K."""

    states = ("soc", "v1", "v2", "temp")
    outputs = ("voltage", "temp")
    inputs = ("current", "ambient")
    default_parameters = {"capacity": 2.35e5, "r0": 0.075, "r1": 0.017, "c1": 700.0,
                          "r2": 0.035, "c2": 7500.0, "heat_capacity": 4.6e5, "cooling": 25.0,
                          "ocv": DATASHEET_OCV}
    initial_state = {"soc": 0.6}

    def derivatives(self, x, u):
        p = self.parameters
        v1, v2, temp = x[..., 1], x[..., 2], x[..., 3]
        current, ambient = u[..., 0], u[..., 1]
        dsoc = -current / p["capacity"]
        dv1 = current / p["c1"] - v1 / (p["r1"] * p["c1"])
        dv2 = current / p["c2"] - v2 / (p["r2"] * p["c2"])
        dtemp = (p["r0"] * current ** 2 - p["cooling"] * (temp - ambient)) / p["heat_capacity"]
        return np.stack([dsoc, dv1, dv2, dtemp], axis=-1)

    def output(self, x, u):
        p = self.parameters
        voltage = p["ocv"](x[..., 0]) - x[..., 1] - x[..., 2] - p["r0"] * u[..., 0]
        return np.stack([voltage, x[..., 3]], axis=-1)


def _drive_speed(rng: np.random.Generator, seconds: int, highway: float) -> np.ndarray:
    """A drive's speed (m/s) per second: legs of acceleration, cruising (with wobble) and,
    mostly in town, braking to a stop and standing; it starts and ends at standstill."""
    legs, speed, length = [], 0.0, 0
    while length < seconds:
        fast = rng.random() < highway
        target = rng.uniform(22.0, 32.0) if fast else rng.uniform(7.0, 17.0)
        rate = rng.uniform(0.8, 1.6) if fast else rng.uniform(1.0, 2.5)
        steps = max(int(abs(target - speed) / rate), 1)
        legs.append(np.linspace(speed, target, steps + 1)[1:])
        cruise = int(rng.uniform(120.0, 900.0) if fast else rng.uniform(15.0, 150.0))
        # a smooth wobble: 1.2 m/s, accelerations of some 0.1 m/s^2
        wobble = lfilter([0.074], [1.0, -1.8, 0.81], rng.normal(0.0, 1.0, cruise))
        legs.append(np.maximum(target + wobble, 0.0))
        speed = float(legs[-1][-1])
        if rng.random() < (0.1 if fast else 0.6):
            braking = rng.uniform(1.0, 2.8)
            legs.append(np.maximum(speed - braking * np.arange(1, int(speed / braking) + 2), 0.0))
            legs.append(np.zeros(int(rng.uniform(5.0, 60.0))))
            speed = 0.0
        length = sum(len(leg) for leg in legs)
    v = np.concatenate(legs)[:seconds]
    # the last stretch: braking at 2 m/s^2 to a stop at the drive's end
    return np.minimum(v, 2.0 * np.arange(seconds - 1, -1, -1))


def _battery_power(v: np.ndarray, ambient: np.ndarray) -> np.ndarray:
    """Pack power (W, positive discharging) of a speed profile (m/s per second) and the
    ambient temperature over it (C): road load, drivetrain and regeneration efficiency and
    limits, cabin climate and DC/DC load."""
    ahead = np.append(v[1:], 0.0)
    accel, mid = ahead - v, 0.5 * (ahead + v)
    force = (MASS * 1.05 * accel + 0.5 * 1.2 * DRAG_AREA * mid ** 2
             + MASS * 9.81 * ROLLING * (mid > 0.1))
    wheel = force * mid
    fade = np.clip(mid / 5.0, 0.0, 1.0)                   # friction brakes at walking pace
    pack = np.where(wheel > 0, np.minimum(wheel / EFFICIENCY, MOTORING_LIMIT),
                    np.maximum(wheel * REGEN * fade, -REGEN_LIMIT))
    climate = np.minimum(60.0 * np.abs(ambient - 21.0), 3000.0)
    return pack + climate + DRIVING_AUX_W


def _day_plan(rng: np.random.Generator) -> tuple[list, list, tuple]:
    """One calendar day's drives ``(start s, seconds, highway share)``, DC sessions
    ``(start s, seconds, amps)`` and AC plug-in ``(start s, threshold)``: plugged in when the
    state of charge is below the threshold (above 1: always)."""
    hours = 3600.0
    kind = rng.random()
    drives, sessions = [], []
    if kind < 0.6:                                        # commuting
        drives.append((rng.uniform(6.5, 9.0) * hours, rng.uniform(15, 45) * 60, 0.15))
        if rng.random() < 0.4:
            drives.append((rng.uniform(12.0, 14.0) * hours, rng.uniform(5, 20) * 60, 0.0))
        drives.append((rng.uniform(16.0, 19.0) * hours, rng.uniform(15, 45) * 60, 0.15))
    elif kind < 0.85:                                     # errands
        drives.append((rng.uniform(9.5, 11.5) * hours, rng.uniform(10, 40) * 60, 0.05))
        drives.append((rng.uniform(14.0, 17.0) * hours, rng.uniform(10, 40) * 60, 0.05))
    else:                                                 # a trip with a fast charge
        first = rng.uniform(8.0, 10.0) * hours
        length = rng.uniform(40, 70) * 60
        drives.append((first, length, 0.7))
        charge_start = first + length + rng.uniform(2, 10) * 60
        charge = rng.uniform(20, 40) * 60
        sessions.append((charge_start, charge, rng.uniform(100.0, 150.0)))
        drives.append((charge_start + charge + rng.uniform(2, 10) * 60,
                       rng.uniform(45, 80) * 60, 0.6))
    last = drives[-1][0] + drives[-1][1]
    if rng.random() < 0.6:
        plug = last + rng.uniform(5, 30) * 60
    else:
        plug = max(22.0 * hours + rng.uniform(0, 60) * 60, last + 60)
    threshold = 1.5 if rng.random() < 0.55 else 0.55
    return drives, sessions, (plug, threshold)


class EvBattery(Family):
    name = "ev_battery"
    title = "EV battery pack (1 Hz)"
    description = ("equivalent-circuit pack over drives, parking, AC and DC charging: smooth "
                   "OCV formula, temperature- and charge-dependent resistance, two RC pairs, "
                   "thermal node with pump cooling; white box: datasheet OCV table, constant "
                   "resistance and cooling, 10-20 % off, hidden state of charge")
    spec = "benchmarks.zoo.families.ev_battery:BatteryWhiteBox"
    columns = {"voltage": "pack_voltage", "temp": "pack_temp", "current": "pack_current",
               "ambient": "ambient_temp"}
    sample_interval = DT
    held_out = False
    channels = ("pack_voltage", "pack_current", "pack_temp", "ambient_temp")
    faults = (
        FaultKind("capacity_fade", "capacity down by m (relative)", (0.05, 0.15)),
        FaultKind("resistance_growth", "ohmic resistance R0 up by m (relative)", (0.15, 0.5)),
        FaultKind("cooling_loss", "thermal conductance to ambient down by m (relative: a "
                  "failing pump, a clogged radiator)", (0.35, 0.75)),
        FaultKind("soft_short", "an internal leakage of m A the current sensor does not see "
                  "(its heat, m A x OCV, in the pack)", (0.1, 0.4)),
        FaultKind("voltage_drift", "the pack-voltage sensor's offset drifts by m V per day "
                  "from the onset on (an ageing divider or reference)", (0.3, 1.0)),
    )

    def true_parameters(self, rng):
        return {"capacity": spread(rng, 2.7e5, 0.02), "r0": spread(rng, 0.065, 0.05),
                "r1": spread(rng, 0.020, 0.05), "tau1": spread(rng, 10.0, 0.05),
                "r2": spread(rng, 0.030, 0.05), "tau2": spread(rng, 300.0, 0.05),
                "heat_capacity": spread(rng, 4.0e5, 0.03), "g_park": spread(rng, 10.0, 0.05),
                "g_drive": spread(rng, 15.0, 0.05), "g_pump": spread(rng, 120.0, 0.05),
                "current_offset": 0.03 * rng.standard_normal(),
                "charge_limit": float(rng.uniform(0.8, 0.95)),
                "ac_current": float(rng.uniform(10.0, 20.0)),
                "climate": float(rng.uniform(2.0, 26.0))}

    def _schedule(self, batch: DayBatch, ambient: np.ndarray):
        """Per element: mode, pack power demand (W), charger current limit (A) and plug-in
        thresholds (at plug-in seconds, else 0) over the warm-up and the day."""
        shape = ambient.shape
        mode = np.full(shape, PARK, dtype=np.int8)
        demand = np.full(shape, STANDBY_W)
        charger = np.zeros(shape)
        threshold = np.zeros(shape)
        total = shape[1]
        for b, rng in enumerate(batch.rngs):
            plans = [_day_plan(rng) for _ in (-1, 0)]
            drives = [(int(WARMUP + d * DAY + s), int(n), hw) for d, (plan, _, _) in
                      zip((-1, 0), plans) for s, n, hw in plan]
            profiles = [_drive_speed(rng, n, hw) for _, n, hw in drives]
            for (start, n, _), speed in zip(drives, profiles):
                lo, hi = max(start, 0), min(start + n, total)
                if hi <= lo:
                    continue
                mode[b, lo:hi] = DRIVE
                seconds = np.clip(np.arange(start, start + n), 0, total - 1)
                demand[b, lo:hi] = _battery_power(speed, ambient[b, seconds])[lo - start:hi - start]
            for d, (_, sessions, (plug, limit)) in zip((-1, 0), plans):
                for start, n, amps in sessions:
                    lo = max(int(WARMUP + d * DAY + start), 0)
                    hi = min(int(WARMUP + d * DAY + start + n), total)
                    if hi > lo:
                        mode[b, lo:hi], charger[b, lo:hi] = DC, amps
                        demand[b, lo:hi] = CHARGING_AUX_W
                begin = int(WARMUP + d * DAY + plug)
                later = [s for s, _, _ in drives if s > begin]
                end = min(later[0] if later else total, total)
                lo = max(begin, 0)
                if end > lo:
                    mode[b, lo:end] = AC                  # the charger feeds the standby load
                    charger[b, lo:end] = batch.true["ac_current"][b]
                    threshold[b, lo] = limit
        return mode, demand, charger, threshold

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        n, t, hour, total = self.clock(WARMUP)
        ambient = ((p["climate"] + batch.uniform(-4.0, 4.0))[:, None]      # the day's weather
                   + batch.uniform(3.0, 7.0)[:, None] * np.sin(2 * np.pi * (hour - 9) / 24)[None, :]
                   + smooth_noise(batch, total, 3600 / DT, 0.4))
        mode, demand, charger, threshold = self._schedule(batch, ambient)
        soc = batch.uniform(0.3, 0.9)
        temp = ambient[:, 0] + batch.uniform(0.0, 5.0)
        v1, v2 = np.zeros(len(batch)), np.zeros(len(batch))
        a1, a2 = np.exp(-DT / p["tau1"]), np.exp(-DT / p["tau2"])
        voltage = open_circuit_voltage(soc, temp)
        plugged = np.zeros(len(batch), dtype=bool)
        pump = np.zeros(len(batch), dtype=bool)
        onset = batch.onset
        growth = (batch.fault == "resistance_growth") * batch.magnitude
        cooling = (batch.fault == "cooling_loss") * batch.magnitude
        short = (batch.fault == "soft_short") * batch.magnitude
        fade = (batch.fault == "capacity_fade") * batch.magnitude
        out = {k: np.empty((len(batch), n)) for k in ("V", "I", "T")}
        for k in range(total):
            on = t[k] >= onset
            m = mode[:, k]
            plugged = np.where(threshold[:, k] > 0, soc < threshold[:, k], plugged)
            fast = m == DC
            target = np.where(fast, DC_TARGET, p["charge_limit"])
            taper = np.clip((target - soc) / np.where(fast, DC_TAPER, AC_TAPER), 0.0, 1.0)
            load = demand[:, k] / voltage
            load *= np.where(load > 0, np.clip((soc - 0.06) / 0.06, 0.0, 1.0),
                             np.clip((0.98 - soc) / 0.03, 0.0, 1.0))
            current = load - charger[:, k] * taper * (plugged | fast)
            warm = np.exp(-0.03 * (temp - 25.0))
            r0 = p["r0"] * warm * (1.0 + 0.25 * np.exp(-soc / 0.12)) * (1.0 + growth * on)
            r1, r2 = p["r1"] * warm, p["r2"] * warm
            ocv = open_circuit_voltage(soc, temp)
            voltage = ocv - v1 - v2 - r0 * current
            if k >= WARMUP:
                j = k - WARMUP
                out["V"][:, j], out["I"][:, j], out["T"][:, j] = voltage, current, temp
            leak = short * on
            heat = r0 * current ** 2 + v1 ** 2 / r1 + v2 ** 2 / r2 + leak * ocv
            soc = soc - DT * (current + leak) / (p["capacity"] * (1.0 - fade * on))
            v1 = a1 * v1 + (1.0 - a1) * r1 * current
            v2 = a2 * v2 + (1.0 - a2) * r2 * current
            pump = fast | ((m != PARK) & ((temp > 33.0) | (pump & (temp > 30.0))))
            conductance = ((p["g_park"] + p["g_drive"] * (m == DRIVE) + p["g_pump"] * pump)
                           * (1.0 - cooling * on))
            temp = temp + DT * (heat - conductance * (temp - ambient[:, k])) / p["heat_capacity"]
        day = slice(WARMUP, total)
        # the drift's offset grows with the time since the onset (onset is day-relative)
        drifted = batch.active("voltage_drift", t[day]) * np.maximum(t[day] - batch.onset[:, None],
                                                                      0.0) / 86400.0
        return {"pack_voltage": quantise(out["V"] + drifted + batch.normal((n,), 0.05), 0.01),
                "pack_current": quantise(out["I"] + p["current_offset"][:, None]
                                         + batch.normal((n,), 0.15), 0.05),
                "pack_temp": quantise(out["T"] + batch.normal((n,), 0.05), 0.1),
                "ambient_temp": quantise(ambient[:, day] + batch.normal((n,), 0.1), 0.01)}


FAMILY = EvBattery()
