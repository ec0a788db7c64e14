"""A 12-m battery-electric city bus's longitudinal dynamics and traction motor, at 1 Hz.

True plant (2 substeps a second): the bus (12.8 t empty, +-3 % per bus, plus 72 kg per
passenger; the wheels' and drivetrain's rotating inertia add 4 % to the translating mass)
``m_eff v' = F_drive - F_brake - F_roll - F_aero - m g sin(grade)`` with ``F_drive = eta G/r
tau`` driving and ``G/(eta r) tau`` regenerating (gear 12, rolling radius 0.48 m less 0-2 %
tread wear, ``eta = 0.95``), rolling resistance ``m g C_rr (1 + v / 30)`` (``C_rr`` 0.0085,
up to 10 % higher on a wet day), drag ``0.5 rho C_d A (v + head wind)^2`` (``C_d A`` 5.8 m^2,
a gusty wind), and pneumatic friction brakes whose force ``k_b (p - 0.4 bar)`` varies with
the pads' friction. The driver follows the route's speed: stops every 250-600 m (dwell 10-60
s; passengers alight and board, the load following the hour of the day and the day's
ridership, lower at weekends: days count from the first simulated day, a Monday in the zoo's
runs), traffic lights, cruising at 30-50 km/h with wobble, accelerating at 0.8-1.3 m/s^2 and
braking at 0.7-1.3 m/s^2 with a jerk-limited torque, regenerating down to 2 m/s and blending
the friction brakes below it and beyond the regenerative limit (-900 N m, 160 kW); at stops
the service brake holds at 1.5-2.5 bar. The route's grade is a function of position (out and
back, +-2.5 %), different every day. Service 5:00-6:30 to 22:00-23:30 with a charging break
at midday; parked at night (the inverter off, the parking brake on). The motor's winding and
its liquid-cooled housing: ``C_w T_w' = k_cu tau^2 (1 + 0.0039 (T_w - 25)) + k_fe omega^1.5 -
(T_w - T_h) / R_wh``, ``C_h T_h' = (T_w - T_h) / R_wh - (T_h - T_amb) / R_ha`` (the coolant
pump runs in service only; natural convection when parked).

Telemetry at 1 Hz: vehicle speed (wheel-speed sensors: 0.01 m/s, 0.03 m/s noise, read 0 below
0.3 m/s), motor torque (the inverter's estimate: 1 % per-bus calibration error, 8 N m noise, 1
N m resolution, 0 when the inverter is off), brake pressure (bar, 0.05 resolution), road grade
(%, from GPS altitude: filtered over about 8 s, 0.4 % slow error and 0.2 % noise, 0.1 %
resolution, 0 below 1 m/s where it cannot be computed), motor winding temperature (0.1 C) and
ambient temperature.

The white box a user writes (:class:`BusWhiteBox`): ``m v' = G/r tau - k_b p tanh(v/0.3) - m g
C_rr tanh(v/0.5) - 0.5 rho C_d A v|v| - m g grade/100`` with a fixed half-load mass and the
new tyre's radius, no drivetrain losses, no rotating inertia, no wind, a linear brake law, and
a one-node motor ``C T' = k tau^2 - (T - T_amb) / R``; parameters 10-20 % off.

Faults and why these magnitudes (fixed from the physics before any detection run):

* ``brake_drag``: a caliper that does not release: m N more resistance while rolling. The bus
  rolls against about 1,200-1,800 N (rolling resistance) plus 100-400 N of drag in town;
  200 N (a pad lightly touching) is small, 700 N (a sticking caliper, a hot wheel) clearly
  large.
* ``tyre_pressure``: rolling resistance up by m (relative): about 20 % under-inflation of all
  tyres gives 10 %; 30 % is half-flat tyres.
* ``speed_gain``: the speed reading x (1 + m): 2 % is a wrong tyre size in the configuration
  or worn-versus-new tread; 6 % is clearly miscalibrated.
* ``torque_noise``: the torque estimate's noise up by m N m rms (a failing current-sensor
  channel): 8 N m doubles its power, 30 N m is gross.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 1.0
SUBSTEPS = 2
WARMUP = 1800
GEAR, RADIUS, ETA, G0, RHO = 12.0, 0.48, 0.95, 9.81, 1.2
TORQUE_MAX, REGEN_MAX, REGEN_POWER, POWER_MAX = 1200.0, 900.0, 1.6e5, 2.5e5
#: the driver: speed error (m/s) to force (N), its integral, the force per bar the brake
#: controller assumes, the mass the driver's feed-forward "feels", torque slew (N m/s)
KP_DRIVER, KI_DRIVER, BRAKE_NOMINAL, MASS_FEEL, SLEW = 6000.0, 600.0, 6000.0, 15000.0, 1500.0


#: the bus runs while it moves: it parks for hours a night, when its speed reads 0 (added
#: after the first zoo run, where every day's read failed as a stuck speed sensor: the
#: product's error now names this setting)
GRID = {"running": {"speed": [0.3, 100.0]}, "intermittent": True}


class BusWhiteBox(WhiteBoxModel):
    """Vehicle speed ``v`` (m/s) and motor winding temperature ``T`` (C); inputs motor torque
    (N m), brake pressure (bar), road grade (%) and ambient temperature (C)."""

    states = ("v", "T")
    inputs = ("torque", "brake", "grade", "ambient")
    controlled_inputs = ("torque", "brake")  # the driver sets them from the bus's speed
    default_parameters = {"mass": 14000.0, "ratio": 12.0 / 0.49, "brake_gain": 5000.0,
                          "c_rr": 0.007, "cda": 5.0, "heat_capacity": 2.4e4,
                          "loss_per_nm2": 0.0072, "thermal_resistance": 0.012}

    def derivatives(self, x, u):
        p = self.parameters
        v, temp = x[..., 0], x[..., 1]
        torque, brake, grade, ambient = (u[..., i] for i in range(4))
        force = (p["ratio"] * torque - p["brake_gain"] * brake * np.tanh(v / 0.3)
                 - p["mass"] * G0 * p["c_rr"] * np.tanh(v / 0.5)
                 - 0.5 * RHO * p["cda"] * v * np.abs(v) - p["mass"] * G0 * grade / 100.0)
        d_temp = (p["loss_per_nm2"] * torque ** 2
                  - (temp - ambient) / p["thermal_resistance"]) / p["heat_capacity"]
        return np.stack([force / p["mass"], d_temp], axis=-1)


def _service(rng: np.random.Generator, seconds: int, warmup: int, ridership: float):
    """One bus-day: reference speed (m/s), passengers aboard, in service (bool), stop hold
    (bool: at a stop with the brake held)."""
    v = np.zeros(seconds)
    aboard = np.zeros(seconds)
    service = np.zeros(seconds, dtype=bool)
    h = 3600
    start = warmup + int(rng.uniform(5.0, 6.5) * h)
    pause = warmup + int(rng.uniform(10.5, 12.5) * h)
    back = pause + int(rng.uniform(1.0, 2.0) * h)
    end = warmup + int(rng.uniform(22.0, 23.5) * h)
    for first, last in ((start, pause), (back, end)):
        t, people, distance = first, 0.0, 0.0
        while t < last - 300:
            hour = ((t - warmup) / h) % 24.0
            demand = ridership * (8.0 + 30.0 * np.exp(-((hour - 8.0) / 1.3) ** 2)
                                  + 25.0 * np.exp(-((hour - 17.0) / 1.8) ** 2)
                                  + 8.0 * np.exp(-((hour - 13.0) / 2.5) ** 2))
            if distance > 9000.0:                       # the terminus: everyone alights
                layover = int(rng.uniform(300, 900))
                aboard[t:t + layover] = 0.0
                t, people, distance = t + layover, 0.0, 0.0
                continue
            gap = rng.uniform(250.0, 600.0)             # to the next stop
            cruise_speed = rng.uniform(8.5, 13.5)
            up = rng.uniform(0.8, 1.3)
            down = rng.uniform(0.7, 1.3)
            pieces = []
            left = gap
            while left > 0:                             # a leg, maybe cut by a red light
                top = min(cruise_speed, np.sqrt(left * up * down / (up + down)))
                accel_d = top ** 2 / (2 * up)
                brake_d = top ** 2 / (2 * down)
                cruise_d = max(left - accel_d - brake_d, 0.0)
                light = rng.random() < 0.3 and cruise_d > 50
                if light:
                    cruise_d *= rng.uniform(0.2, 0.8)
                n_up, n_down = max(int(top / up), 1), max(int(top / down), 1)
                n_cruise = int(cruise_d / top)
                wobble = lfilter([0.02], [1.0, -0.98], rng.normal(0.0, 1.0, n_cruise))
                pieces += [np.linspace(0.0, top, n_up + 1)[1:],
                           np.clip(top + wobble, 1.0, None),
                           np.linspace(top, 0.0, n_down + 1)[1:]]
                left -= accel_d + brake_d + cruise_d
                if light:
                    pieces.append(np.zeros(int(rng.uniform(10, 60))))
            leg = np.concatenate(pieces)
            stop = t + len(leg)
            v[t:stop] = leg
            aboard[t:stop] = people
            t, distance = stop, distance + gap
            # the stop: some alight, some board
            dwell = int(rng.uniform(10, 25) + rng.uniform(0, 35) * min(demand / 40.0, 1.0))
            alight = rng.binomial(int(people), 0.15) if people >= 1 else 0
            board = rng.poisson(demand / 10.0)
            people = float(np.clip(people - alight + board, 0, 90))
            stop = t + dwell
            aboard[t:stop] = np.linspace(aboard[t - 1], people, stop - t + 1)[1:]
            t = stop
        aboard[t:last] = people
        service[first:max(t, last)] = True           # a last leg may end after the hour
    return v, aboard, service


class BusLongitudinal(Family):
    name = "bus_longitudinal"
    title = "Electric city bus, longitudinal (1 Hz)"
    description = ("12-m e-bus in stop-and-go service: passengers boarding at stops, weekend "
                   "ridership, drivetrain losses, rotating inertia, wet-road rolling, gusts, "
                   "blended regenerative and pneumatic braking, GPS grade, two-node motor "
                   "thermal; white box: fixed mass, no losses, linear brake, one-node motor, "
                   "10-20 % off")
    spec = "benchmarks.zoo.families.bus_longitudinal:BusWhiteBox"
    columns = {"v": "speed", "T": "motor_temp", "torque": "motor_torque",
               "brake": "brake_pressure", "grade": "road_grade", "ambient": "ambient_temp"}
    sample_interval = DT
    grid = GRID
    held_out = True
    channels = ("speed", "motor_temp", "motor_torque", "brake_pressure", "road_grade",
                "ambient_temp")
    faults = (
        FaultKind("brake_drag", "a dragging brake: m N more resistance while rolling",
                  (200.0, 700.0)),
        FaultKind("tyre_pressure", "rolling resistance up by m (relative: under-inflated "
                  "tyres)", (0.1, 0.3)),
        FaultKind("speed_gain", "speed sensor reads x (1 + m)", (0.02, 0.06)),
        FaultKind("torque_noise", "motor torque estimate's noise up by m N m rms",
                  (8.0, 30.0)),
    )

    def true_parameters(self, rng):
        return {"mass": spread(rng, 12800.0, 0.03), "c_rr": spread(rng, 0.0085, 0.05),
                "cda": spread(rng, 5.8, 0.04), "wear": float(rng.uniform(0.0, 0.02)),
                "brake_gain": spread(rng, 6000.0, 0.08), "torque_cal": spread(rng, 1.0, 0.01),
                "c_winding": spread(rng, 1.5e4, 0.05), "c_housing": spread(rng, 6.0e4, 0.05),
                "r_wh": spread(rng, 0.01, 0.05), "r_ha": spread(rng, 0.004, 0.05),
                "k_cu": spread(rng, 0.0083, 0.05), "k_fe": spread(rng, 0.29, 0.08),
                "climate": float(rng.uniform(0.0, 25.0))}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        size = len(batch)
        n, t, hour, total = self.clock(WARMUP)
        weekend = (batch.day % 7) >= 5
        ridership = np.where(weekend, batch.uniform(0.35, 0.7), batch.uniform(0.7, 1.3))
        plans = [_service(rng, total + 1, WARMUP, r) for rng, r in zip(batch.rngs, ridership)]
        reference = np.stack([a for a, _, _ in plans])
        aboard = np.stack([b for _, b, _ in plans])[:, :total]
        service = np.stack([c for _, _, c in plans])[:, :total]
        mass = p["mass"][:, None] + 72.0 * aboard                     # (B, total)
        inertia = 1.04 * mass
        # the route's grade by position (out and back), the driver's speed as position
        position = np.cumsum(reference[:, :total], axis=1)
        half = 9000.0
        profile = np.clip(smooth_noise(batch, 2000, 20.0, 2.5), -6.0, 6.0)   # % per 10 m
        folded = position % (2 * half)
        index = np.minimum((np.where(folded < half, folded, 2 * half - folded) / 10.0).astype(int),
                           1999)
        sign = np.where(folded < half, 1.0, -1.0)
        grade = np.take_along_axis(profile, index, axis=1) * sign     # %
        wet = np.where(batch.uniform(0.0, 1.0) < 0.35, batch.uniform(1.0, 1.1), 1.0)[:, None]
        hold_pressure = batch.uniform(1.5, 2.5)
        wind = smooth_noise(batch, total, 30.0, 1.5)
        ambient = ((p["climate"] + batch.uniform(-4.0, 4.0))[:, None]
                   + batch.uniform(3.0, 6.0)[:, None] * np.sin(2 * np.pi * (hour - 9) / 24)[None, :]
                   + smooth_noise(batch, total, 1800.0, 0.4))
        pedal = smooth_noise(batch, total, 3.0, 150.0)                # N of the driver's jitter
        radius = RADIUS * (1 - p["wear"])
        rolling = (p["c_rr"][:, None] * wet) * (1 + batch.active("tyre_pressure", t))
        drag_fault = batch.active("brake_drag", t)
        pad = 1 + 0.05 * smooth_noise(batch, total, 600.0)            # pad friction drifts

        v = np.zeros(size)
        torque = np.zeros(size)
        integral = np.zeros(size)
        pressure = np.zeros(size)
        t_w = ambient[:, 0] + 2.0
        t_h = ambient[:, 0] + 1.0
        out = {k: np.empty((size, n)) for k in ("v", "tau", "p", "T")}
        h = DT / SUBSTEPS
        up_drive, down_regen = ETA * GEAR / radius, GEAR / (ETA * radius)
        for k in range(total):
            ref0, ref1 = reference[:, k], reference[:, k + 1]
            a_ref = ref1 - ref0
            m, m_eff = mass[:, k], inertia[:, k]
            on = service[:, k]
            at_stop = (ref0 == 0) & (ref1 == 0)
            driving = on & ~at_stop
            hold = ~driving                                  # the stop brake or the parking brake
            slope = m * G0 * np.sin(np.arctan(grade[:, k] / 100.0))
            roll = m * G0 * rolling[:, k]
            air = v + wind[:, k]
            # within the second: the motor's limits at its start, the road load held
            omega = v * GEAR / radius
            drive_max = np.minimum(TORQUE_MAX, POWER_MAX / np.maximum(omega, 1.0))
            regen_max = (np.minimum(REGEN_MAX, REGEN_POWER / np.maximum(omega, 1.0))
                         * np.clip(v - 1.0, 0.0, 1.0))
            load = 0.5 * RHO * p["cda"] * air * np.abs(air) + drag_fault[:, k]
            squared = np.zeros(size)
            for j in range(SUBSTEPS):
                error = ref0 + a_ref * (j / SUBSTEPS) - v
                integral = np.where(driving, np.clip(integral + KI_DRIVER * h * error,
                                                     -3000.0, 3000.0), 0.0)
                wanted = MASS_FEEL * a_ref + KP_DRIVER * error + integral + pedal[:, k]
                command = np.where(driving, np.clip(wanted * (radius / GEAR), -regen_max,
                                                    drive_max), 0.0)
                torque = np.clip(command, torque - SLEW * h, torque + SLEW * h)
                drive = np.where(torque >= 0, up_drive, down_regen) * torque
                # the brake controller blends in the friction brakes for what regen lacks
                rest = np.where(wanted < 0, np.maximum(np.minimum(drive, 0.0) - wanted, 0.0), 0.0)
                pressure = np.where(driving, rest / BRAKE_NOMINAL + 0.4 * (rest > 0),
                                    np.where(on, hold_pressure, 0.0))
                brake = p["brake_gain"] * pad[:, k] * np.maximum(pressure - 0.4, 0.0)
                moving = v > 0.0
                push = drive - slope
                resist = roll * (1 + v / 30.0) + brake + load
                accel = np.where(moving, (push - resist) / m_eff, 0.0)
                # from a standstill it moves off only if the push overcomes brakes and tyres
                start = ~moving & (push > brake + roll) & driving
                accel = np.where(start, (push - brake - roll) / m_eff, accel)
                v = np.maximum(v + h * accel, 0.0)
                v = np.where(hold & (v < 0.3), 0.0, v)
                squared += torque * torque
            if k >= WARMUP:
                i = k - WARMUP
                out["v"][:, i], out["tau"][:, i], out["p"][:, i] = v, torque, pressure
                out["T"][:, i] = t_w
            # the motor's winding and housing, once a second
            omega = v * GEAR / radius
            loss = (p["k_cu"] * squared / SUBSTEPS * (1 + 0.0039 * (t_w - 25.0))
                    + p["k_fe"] * omega ** 1.5)
            r_ha = np.where(on, p["r_ha"], 4 * p["r_ha"])
            t_w = t_w + DT * (loss - (t_w - t_h) / p["r_wh"]) / p["c_winding"]
            t_h = t_h + DT * ((t_w - t_h) / p["r_wh"] - (t_h - ambient[:, k]) / r_ha) / p["c_housing"]
        day = slice(WARMUP, total)
        on = service[:, day]
        speed = out["v"] * (1 + batch.active("speed_gain", t[day]))
        speed = np.where(out["v"] > 0.3, speed + batch.normal((n,), 0.03), 0.0)
        torque_noise = np.sqrt(8.0 ** 2 + batch.active("torque_noise", t[day]) ** 2)
        torque_read = np.where(on, out["tau"] * p["torque_cal"][:, None]
                               + batch.normal((n,), 1.0) * torque_noise, 0.0)
        gps = lfilter([1 / 8.0], [1.0, -7 / 8.0], grade[:, day], axis=1)
        gps = gps + smooth_noise(batch, n, 60.0, 0.4) + batch.normal((n,), 0.2)
        gps = np.where(out["v"] > 1.0, gps, 0.0)
        return {"speed": quantise(np.maximum(speed, 0.0), 0.01),
                "motor_temp": quantise(out["T"] + batch.normal((n,), 0.1), 0.1),
                "motor_torque": quantise(torque_read, 1.0),
                "brake_pressure": quantise(out["p"] + batch.normal((n,), 0.02) * (out["p"] > 0), 0.05),
                "road_grade": quantise(gps, 0.1),
                "ambient_temp": quantise(ambient[:, day] + batch.normal((n,), 0.2), 0.1)}


FAMILY = BusLongitudinal()
