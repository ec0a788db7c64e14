"""An industrial drum boiler (natural circulation, gas fired) raising process steam for a
chemical plant that runs around the clock, logged every 5 s by the plant's DCS.

True plant (1-s substeps, explicit Euler): the Åström-Bell (2000) drum-boiler model, four
states: the circuit's total water volume ``Vwt``, the drum pressure ``p``, the riser-exit
steam quality ``a_r`` and the steam volume under the drum's liquid level ``Vsd``.

* Global mass and energy balances of the water, steam and metal of the whole circuit
  (drum ``Vd`` about 10.8 m^3: a 1.4-m by 7-m drum; risers ``Vr`` about 6 m^3; downcomers and
  mud drum ``Vdc`` about 2.5 m^3; 80 t of metal at the saturation temperature)::

      e11 dVwt/dt + e12 dp/dt = qf - qs - q_lost
      e21 dVwt/dt + e22 dp/dt = Q + qf hf - qs hs - q_lost h_lost

  with ``e11 = rho_w - rho_s``, ``e12 = Vwt rho_w' + Vst rho_s'``, ``e21 = rho_w h_w -
  rho_s h_s``, ``e22 = Vwt (h_w rho_w' + rho_w h_w') + Vst (h_s rho_s' + rho_s h_s') - Vt +
  m_t c_p T_s'`` (primes: d/dp). The saturation properties are quadratics in the pressure
  through the IF97 values at 30, 40 and 50 bar (the plant runs at 38-43 bar abs): at 40 bar
  the stored energy is about 124 MJ per bar, so a 10 % (2.4 MW) firing mismatch moves the
  pressure by about 1.2 bar a minute.
* The risers' energy balance (the steam quality) and the drum's steam balance (the bubbles
  below the level, condensed by the subcooled feedwater, escaping through the surface with a
  residence time ``Td`` about 12 s), with the Zuber-type mean void fraction
  ``av = rho_w / (rho_w - rho_s) (1 - rho_s / ((rho_w - rho_s) a_r) ln(1 + (rho_w - rho_s)
  a_r / rho_s))`` and the natural circulation ``qdc = sqrt(2 rho_w Adc (rho_w - rho_s) g av Vr
  / k)`` (``k`` sized for a circulation ratio of about 12 at full load). The level is
  ``(Vwd + Vsd) / Ad`` (``Ad`` about 9.8 m^2 at the normal water level), ``Vwd = Vwt - Vdc -
  (1 - av) Vr``: *shrink and swell*. A step up in the steam drawn drops the pressure, water
  flashes in the risers, the void grows and the level first rises (simulated: about 15-30 mm
  a minute after a 2.5-5 t/h step), then falls 10-20 mm below as the three-element
  controller feeds the colder water.

The controls: a pressure (firing-rate) controller, PI on the drum pressure (``Kp`` about
500 Nm^3/h per bar, ``Ti`` about 100 s) with a feedforward from the measured steam flow,
sets the gas flow (3-s valve lag, 20-110 % of full fire), whose heat reaches the water with
the furnace's lag (25 s): ``Q = eta_evap (1 - fouling) LHV fuel``, ``eta_evap`` 0.72 at full
fire to 0.78 at low fire (the radiant share grows at low fire). A three-element level
controller sets the feedwater flow: the measured steam flow plus a PI on the drum level
(``Kp`` about 0.06 kg/s per mm, ``Ti`` about 600 s); the feedwater flow loop makes the
*measured* feedwater flow follow that demand with a 5-s lag (so a meter error changes the
water actually fed). The steam drawn is the process's demand times ``sqrt(p / p_set)``.
Continuous blowdown (1-2.5 % of the feed, by the asset's water chemistry) and a bottom
blowdown at each shift (20 s at about 4 kg/s) leave the circuit unmetered.

The gas side (on the 5-s grid): the flue gas (about 16 kW/K of heat capacity flow at full
fire, 15 % excess air) leaves the evaporator at ``T_air + (0.9 P_fuel - Q) / (m cp)`` (about
350 C at full fire); an economiser (effectiveness 0.65, water about 2 minutes of hold-up)
heats the feedwater from the deaerator (105 C +- 1.5 K) to the drum inlet (140-160 C) and the
stack gas leaves at about 195 C on the day's mean, 130-250 C with the firing rate (a
thermocouple with a 30-s lag).

The process's demand (kg/s, 1-s resolution): a base of 45-60 % of the boiler's rating
(40 t/h, 11.1 kg/s, +-3 % by the unit) by the asset, +-7 % by the day, 8 % of rating more in
the two day shifts (6-22 h), 4-6 batch users (reactors' jackets, strippers: 4-12 % of the
rating each) switching on for 8-45 minutes and off for 10-80 (their valves and the header:
a 20-s lag), and the rest of the site's users wandering (1.5 % of rating, 2-minute
correlation; 0.5 %, 5 s). Unmeasured day-to-day conditions: the gas's heating value (Wobbe
index, +-0.6 % by the day, 0.3 % wander over hours), the combustion air (5-30 C by the day),
the excess air (+-3 % in the gas's heat capacity flow).

Telemetry at 5 s (the DCS's snapshots): steam flow (t/h, 0.01, 0.5 % noise, the orifice's
calibration +-1 % by the asset), feedwater temperature at the drum inlet (C, 0.1, 0.2 C
noise), fuel gas flow (Nm^3/h, 1, 0.5 % noise), feedwater flow (t/h, 0.01, 0.5 % noise,
+-1 % calibration), drum pressure (bar g, 0.01, 0.02 bar noise), drum level (mm from the
normal water level, 1 mm, the surface's turbulence 2 mm (5-s correlation, also seen by the
controller) and 3 mm of transmitter noise) and flue gas temperature at the stack (C, 1,
1 C noise).

The white box a plant engineer writes (:class:`DrumBoilerWhiteBox`): the level a lumped mass
balance ``dL/dt = (qf - (1 + b) qs) / (rho A)`` (no shrink or swell, the blowdown ``b`` a
fixed 2 % of the steam), the pressure a first-order energy balance ``C dp/dt = eta LHV fuel -
qs (h_s - c_w T_fw)`` (a constant steam enthalpy and efficiency, no flashing), the stack
temperature a first-order lag (2 min) to a linear map of the firing rate. Its parameters are
10-20 % off the fleet's: ``rho A`` from the drum's dimensions with cold water (8.9 kg/mm
against about 7.8), ``C`` from the water and metal inventory (105 MJ/bar against about 124),
``eta`` the boiler's nameplate efficiency less the economiser's share as the engineer
estimates it (0.82 against 0.72-0.78). The feedwater flow and the fuel flow are set by the
plant's loops from its own state: ``controlled_inputs``.

Faults and why these magnitudes (fixed from the physics before any detection run):

* ``tube_leak``: water lost from the circuit (a pinhole or a cracked riser), ``m`` kg/s at
  the set pressure (``sqrt(p)``), leaving with the saturated water's enthalpy. 0.08 kg/s
  (290 kg/h, 0.7 % of the rating, about 1 % of the mean feed) is at the edge of what a
  mass balance sees against the meters' calibration and the blowdown's variation; 0.3 kg/s
  (1.1 t/h) is a leak an operator hears and a tube that fails within weeks.
* ``fireside_fouling``: the evaporator's heat absorbed down by ``m`` for the same heat
  released (deposits on the tubes from a poorly burning gas or a dirty fuel switch): more gas
  for the same steam, a hotter stack, and a hotter feedwater (the economiser takes up part of
  the heat the evaporator lost). 2.5 % (simulated, a day of seed 11) is 0.9 % more gas, 14 K
  of stack and 8 K of feedwater; 7 % is 2.4 % more gas, 39 K of stack (about 2 points of
  efficiency: a cleaning at the next outage) and 24 K of feedwater.
* ``feedwater_meter``: the feedwater flow meter reading high by ``m`` (relative: a drifting
  DP transmitter span), so the loop feeds less water for the same reading and the level
  integral makes up the difference. 1.5 % is within a meter's tolerance band twice over;
  4 % is a meter to recalibrate now (the mass balance off by 0.2-0.4 kg/s).
* ``safety_valve_passing``: a drum safety valve passing steam upstream of the steam meter:
  ``m`` kg/s at the set pressure (choked flow, proportional to ``p``). 0.06 kg/s (220 kg/h)
  is a simmering valve; 0.25 kg/s (900 kg/h) is audible, wastes 0.6 MW and erodes the seat.

The simulation costs about 20-30 s of CPU per batch of 96 asset-days (a 1-s Euler loop of the
4-state model and two PI loops over the batch, the gas side on the 5-s grid).
"""
from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 5.0
#: substeps per sample (1 s)
SUBSTEPS = 5
H = DT / SUBSTEPS
#: samples of warm-up: the previous day's last hour
WARMUP = 720
#: the boiler's rating (40 t/h of steam), kg/s
MCR = 40.0 / 3.6
#: kW of heat released per Nm^3/h of natural gas (LHV 35.8 MJ/Nm^3)
KW_PER_NM3H = 35.8e3 / 3600.0
#: Nm^3/h of gas at full fire
FUEL_MAX = 3300.0
G = 9.81
CP_METAL = 0.5          # kJ/(kg K)
#: drum, risers, downcomers (m^3), drum's surface at the normal water level (m^2)
VD, VR, VDC, AD = 10.8, 6.0, 2.5, 9.8
VT = VD + VR + VDC
#: the drum's volume below the normal water level
V_NWL = 0.5 * VD
ADC = 0.07               # downcomers' flow area, m^2
BETA = 0.3

_P = np.array([30.0, 40.0, 50.0])          # bar abs, IF97 saturation
_RHO_W = np.polyfit(_P, [821.9, 798.7, 777.7], 2)
_RHO_S = np.polyfit(_P, [15.00, 20.09, 25.35], 2)
_H_W = np.polyfit(_P, [1008.3, 1087.4, 1154.5], 2)
_H_S = np.polyfit(_P, [2803.2, 2800.8, 2794.2], 2)
_T_S = np.polyfit(_P, [233.85, 250.35, 263.94], 2)


def _prop(c, p):
    """A quadratic property and its derivative at ``p``."""
    return (c[0] * p + c[1]) * p + c[2], 2.0 * c[0] * p + c[1]


def _h_feed(temp):
    """Compressed water's enthalpy (kJ/kg) at ``temp`` C (about 45 bar)."""
    return (4.18 + 0.00035 * temp) * temp


def _void(rw, rs, ar):
    """The risers' mean volume fraction of steam and its derivative in the exit quality."""
    r = rw - rs
    eta = ar * r / rs
    log = np.log1p(eta)
    av = rw / r * (1.0 - log / eta)
    dav = rw / rs * (log / eta ** 2 - 1.0 / (eta * (1.0 + eta)))
    return av, dav


def _circulation(rw, rs, av, k):
    return np.sqrt(2.0 * rw * ADC * (rw - rs) * G * av * VR / k)


def _derivatives(vwt, p, ar, vsd, qf, qs, q_lost, h_lost, heat, hf, par):
    """The Åström-Bell model's derivatives (p in bar, energies in kJ, flows in kg/s)."""
    rw, rw_p = _prop(_RHO_W, p)
    rs, rs_p = _prop(_RHO_S, p)
    hw, hw_p = _prop(_H_W, p)
    hs, hs_p = _prop(_H_S, p)
    _, ts_p = _prop(_T_S, p)
    hc = hs - hw
    vst = VT - vwt
    av, dav_dar = _void(rw, rs, ar)
    delta = 0.01
    av2, _ = _void(rw + rw_p * delta, rs + rs_p * delta, ar)
    dav_dp = (av2 - av) / delta
    qdc = _circulation(rw, rs, av, par["k"])
    e11 = rw - rs
    e12 = vwt * rw_p + vst * rs_p
    e21 = rw * hw - rs * hs
    e22 = (vwt * (hw * rw_p + rw * hw_p) + vst * (hs * rs_p + rs * hs_p) - 100.0 * VT
           + par["m_total"] * CP_METAL * ts_p)
    mass = qf - qs - q_lost
    energy = heat + qf * hf - qs * hs - q_lost * h_lost
    det = e11 * e22 - e12 * e21
    d_vwt = (e22 * mass - e12 * energy) / det
    d_p = (e11 * energy - e21 * mass) / det
    e32 = ((rw * hw_p - ar * hc * rw_p) * (1.0 - av) * VR
           + ((1.0 - ar) * hc * rs_p + rs * hs_p) * av * VR
           + (rs + (rw - rs) * ar) * hc * VR * dav_dp - 100.0 * VR
           + par["m_riser"] * CP_METAL * ts_p)
    e33 = ((1.0 - ar) * rs + ar * rw) * hc * VR * dav_dar
    d_ar = (heat - ar * hc * qdc - e32 * d_p) / e33
    vwd = vwt - VDC - (1.0 - av) * VR
    e42 = (vsd * rs_p + (rs * vsd * hs_p + rw * vwd * hw_p - 100.0 * (vsd + vwd)
                         + par["m_drum"] * CP_METAL * ts_p) / hc
           + ar * (1.0 + BETA) * VR * (av * rs_p + (1.0 - av) * rw_p + (rs - rw) * dav_dp))
    e43 = ar * (1.0 + BETA) * (rs - rw) * VR * dav_dar
    d_vsd = (rs / par["td"] * (par["vsd0"] - vsd) + (hf - hw) / hc * qf
             - e42 * d_p - e43 * d_ar) / rs
    level = (vwd + vsd - V_NWL) / AD * 1000.0
    return d_vwt, d_p, d_ar, d_vsd, level, hw


def _steady(p, qs, q_lost, heat, hf, par):
    """A steady state at pressure ``p`` (bar abs) for the level at the normal water level:
    ``(vwt, a_r, vsd)``."""
    rw, _ = _prop(_RHO_W, p)
    rs, _ = _prop(_RHO_S, p)
    hw, _ = _prop(_H_W, p)
    hs, _ = _prop(_H_S, p)
    hc = hs - hw
    ar = np.full_like(p, 0.08)
    for _ in range(40):
        av, _ = _void(rw, rs, ar)
        ar = np.clip(heat / (hc * _circulation(rw, rs, av, par["k"])), 0.005, 0.5)
    av, _ = _void(rw, rs, ar)
    qf = qs + q_lost
    vsd = par["vsd0"] + par["td"] * (hf - hw) / hc * qf / rs
    vwd = V_NWL - vsd
    return vwd + VDC + (1.0 - av) * VR, ar, vsd


class DrumBoilerWhiteBox(WhiteBoxModel):
    """Drum level (mm), drum pressure (bar g) and stack temperature (C) as states; inputs the
    steam flow and feedwater flow (t/h), the fuel gas flow (Nm^3/h) and the feedwater
    temperature (C)."""

    states = ("level", "pressure", "flue")
    inputs = ("steam", "feedwater", "fuel", "feedwater_temp")
    controlled_inputs = ("feedwater", "fuel")   # the level loop and the firing-rate loop
    default_parameters = {"rho_area": 8.9,          # kg per mm of level
                          "blowdown": 0.02,         # of the steam flow
                          "capacity": 1.05e5,       # kJ per bar
                          "efficiency": 0.82,       # of the gas's LHV reaching the water
                          "lhv": 9.94,              # kWh per Nm^3
                          "h_steam": 2800.0,        # kJ/kg
                          "cp_water": 4.4,          # kJ/(kg K), feedwater enthalpy per C
                          "flue_base": 140.0, "flue_per_fuel": 0.016, "flue_lag": 120.0}
    positive = ("rho_area", "capacity", "efficiency", "lhv", "h_steam", "cp_water",
                "flue_lag")

    def derivatives(self, x, u):
        p = self.parameters
        flue = x[..., 2]
        steam, feed, fuel, t_feed = (u[..., 0] / 3.6, u[..., 1] / 3.6, u[..., 2], u[..., 3])
        level = (feed - (1.0 + p["blowdown"]) * steam) / p["rho_area"]
        heat = p["efficiency"] * p["lhv"] * fuel - steam * (p["h_steam"] - p["cp_water"] * t_feed)
        target = p["flue_base"] + p["flue_per_fuel"] * fuel
        return np.stack([level, heat / p["capacity"], (target - flue) / p["flue_lag"]], axis=-1)


def _schedule(rng: np.random.Generator, steps: int, users: int) -> np.ndarray:
    """One day's batch users (fraction of the rating per 1-s substep, before the header's
    lag): each switching on for 8-45 minutes and off for 10-80."""
    out = np.zeros(steps)
    for _ in range(users):
        size = rng.uniform(0.04, 0.12)
        at = int(rng.uniform(0.0, 80.0) * 60.0 / H)
        on = bool(rng.random() < 0.4)
        at = 0 if on else at
        while at < steps:
            length = int(rng.uniform(8.0, 45.0) * 60.0 / H)
            out[at: at + length] += size
            at += length + int(rng.uniform(10.0, 80.0) * 60.0 / H)
    return out


def _blowdowns(rng: np.random.Generator, steps: int) -> np.ndarray:
    """The bottom blowdowns (kg/s per substep): one per shift, 20 s at about 4 kg/s."""
    out = np.zeros(steps)
    for shift in range(4):          # the warm-up's hour and the day's three shifts
        start = shift * 8.0 * 3600.0 / H if shift else 0.0
        at = int(start + rng.uniform(0.5, 6.0) * 3600.0 / H)
        if at < steps:
            out[at: at + int(20.0 / H)] = rng.uniform(3.5, 4.5)
    return out


class DrumBoiler(Family):
    name = "drum_boiler"
    title = "Industrial drum boiler raising process steam (5 s)"
    description = ("Åström-Bell drum boiler (shrink and swell, natural circulation), PI firing "
                   "rate with steam feedforward and furnace lag, three-element level control, "
                   "blowdowns, economiser and stack; process demand with batch users; white "
                   "box: level mass balance, first-order pressure energy balance, lagged "
                   "linear stack temperature, 10-20 % off")
    spec = "benchmarks.zoo.families.drum_boiler:DrumBoilerWhiteBox"
    columns = {"level": "drum_level", "pressure": "drum_pressure", "flue": "flue_gas_temp",
               "steam": "steam_flow", "feedwater": "feedwater_flow", "fuel": "fuel_flow",
               "feedwater_temp": "feedwater_temp"}
    sample_interval = DT
    held_out = True
    channels = ("steam_flow", "feedwater_temp", "fuel_flow", "feedwater_flow", "drum_pressure",
                "drum_level", "flue_gas_temp")
    batch_size = 96
    faults = (
        FaultKind("tube_leak", "water lost from the circuit, m kg/s at the set pressure",
                  (0.08, 0.3)),
        FaultKind("fireside_fouling", "the evaporator's heat absorbed down by m (relative)",
                  (0.025, 0.07)),
        FaultKind("feedwater_meter", "the feedwater flow meter reading high by m (relative)",
                  (0.015, 0.04)),
        FaultKind("safety_valve_passing", "a safety valve passing m kg/s of steam at the set "
                  "pressure, upstream of the steam meter", (0.06, 0.25)),
    )

    def true_parameters(self, rng):
        return {"mcr": spread(rng, MCR, 0.03), "k": spread(rng, 108.0, 0.08),
                "m_total": spread(rng, 80e3, 0.05), "m_riser": spread(rng, 30e3, 0.05),
                "m_drum": spread(rng, 15e3, 0.05), "td": spread(rng, 12.0, 0.1),
                "vsd0": spread(rng, 2.6, 0.08), "p_set": float(rng.uniform(39.0, 42.0)),
                "kp_p": spread(rng, 500.0, 0.1), "ti_p": spread(rng, 100.0, 0.1),
                "ff": spread(rng, 295.0, 0.05), "kp_l": spread(rng, 0.06, 0.1),
                "ti_l": spread(rng, 600.0, 0.1), "eta_full": spread(rng, 0.72, 0.015),
                "eco": spread(rng, 0.65, 0.04), "blowdown": float(rng.uniform(0.01, 0.025)),
                "base": float(rng.uniform(0.45, 0.6)), "users": float(rng.integers(4, 7)),
                "steam_cal": 1.0 + 0.01 * float(rng.standard_normal()),
                "feed_cal": 1.0 + 0.01 * float(rng.standard_normal())}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        size = len(batch)
        n, t, hour, total = self.clock(WARMUP)
        _, ts, hs, steps = self.clock(WARMUP, SUBSTEPS)
        mcr = p["mcr"]
        # -- the process's demand (kg/s) on the 1-s grid ----------------------------------------
        base = p["base"] * batch.uniform(0.93, 1.07)
        shifts = 0.5 * (np.tanh((hs - 6.0) / 0.25) - np.tanh((hs - 22.0) / 0.25))
        users = np.stack([_schedule(rng, steps, int(u)) for rng, u in zip(batch.rngs, p["users"])])
        lag = np.exp(-H / 20.0)
        users = lfilter([1.0 - lag], [1.0, -lag], users, axis=1, zi=users[:, :1] * lag)[0]
        demand = (base[:, None] + 0.08 * shifts[None, :] + users
                  + smooth_noise(batch, steps, 120.0 / H, 0.015)
                  + smooth_noise(batch, steps, 5.0 / H, 0.005))
        demand = np.clip(demand, 0.2, 1.05) * mcr[:, None]
        bottom = np.stack([_blowdowns(rng, steps) for rng in batch.rngs])
        turbulence = smooth_noise(batch, steps, 5.0 / H, 2.0)
        # -- unmeasured day-to-day conditions ----------------------------------------------------
        lhv = (1.0 + 0.006 * batch.normal(()))[:, None] * (
            1.0 + 0.003 * smooth_noise(batch, total, 3 * 3600.0 / DT))
        t_air = batch.uniform(5.0, 30.0)
        gas_cp = 0.00498 * (1.0 + 0.03 * batch.normal(()))      # kW/K per Nm^3/h
        t_da = 105.0 + 1.5 * smooth_noise(batch, total, 3600.0 / DT)
        blowdown = p["blowdown"] * (1.0 + 0.1 * batch.normal(()))
        # -- faults ----------------------------------------------------------------------------
        leak = batch.active("tube_leak", ts)
        fouling = batch.active("fireside_fouling", ts)
        meter = batch.active("feedwater_meter", ts)
        valve = batch.active("safety_valve_passing", ts)
        # -- the initial steady state ------------------------------------------------------------
        p_set = p["p_set"] + 1.013                  # bar abs
        pressure = p_set.copy()
        qs0 = demand[:, 0]
        t_feed = np.full(size, 150.0)
        hf = _h_feed(t_feed)
        lost0 = blowdown * qs0
        eta = p["eta_full"] + 0.06 * (1.0 - qs0 / mcr)
        heat = qs0 * (2800.0 - hf) + lost0 * 1087.0
        vwt, ar, vsd = _steady(pressure, qs0, lost0, heat, hf, p)
        fuel = heat / (eta * KW_PER_NM3H * lhv[:, 0])
        fuel_cmd = fuel.copy()
        integral_p = fuel - p["ff"] * qs0 * p["steam_cal"]
        feed_meter = (qs0 + lost0) * p["feed_cal"]
        integral_l = feed_meter - qs0 * p["steam_cal"]
        level = np.zeros(size)
        gas1 = np.full(size, 330.0)
        stack = np.full(size, 190.0)
        thermocouple = stack.copy()
        k_fuel, k_furnace, k_feed = (np.exp(-H / tau) for tau in (3.0, 25.0, 5.0))
        k_eco, k_tc = np.exp(-DT / 120.0), np.exp(-DT / 30.0)
        out = {c: np.zeros((size, n)) for c in ("steam", "fuel", "feed", "pressure", "level",
                                                "t_feed", "stack")}
        for k in range(total):
            for j in range(SUBSTEPS):
                s = k * SUBSTEPS + j
                qs = demand[:, s] * np.sqrt(pressure / p_set)
                steam_meter = qs * p["steam_cal"]
                seen = level + turbulence[:, s]
                # firing-rate controller
                error = p_set - pressure
                integral_p = integral_p + H * p["kp_p"] / p["ti_p"] * error
                integral_p = np.clip(integral_p, -0.3 * FUEL_MAX, FUEL_MAX)
                fuel_cmd = np.clip(p["ff"] * steam_meter + p["kp_p"] * error + integral_p,
                                   0.2 * FUEL_MAX, 1.1 * FUEL_MAX)
                fuel = k_fuel * fuel + (1 - k_fuel) * fuel_cmd
                eta = p["eta_full"] + 0.06 * (1.0 - fuel / FUEL_MAX)
                released = fuel * KW_PER_NM3H * lhv[:, k]
                heat = k_furnace * heat + (1 - k_furnace) * eta * (1.0 - fouling[:, s]) * released
                # three-element level controller and the feedwater flow loop
                integral_l = integral_l - H * p["kp_l"] / p["ti_l"] * seen
                feed_cmd = np.maximum(steam_meter - p["kp_l"] * seen + integral_l, 0.0)
                feed_meter = k_feed * feed_meter + (1 - k_feed) * feed_cmd
                qf = feed_meter / (p["feed_cal"] * (1.0 + meter[:, s]))
                # losses: blowdowns and tube leak (water), safety valve (steam)
                ratio = pressure / p_set
                water_lost = blowdown * qf + bottom[:, s] + leak[:, s] * np.sqrt(ratio)
                steam_lost = valve[:, s] * ratio
                rw_h = _prop(_H_W, pressure)[0]
                rs_h = _prop(_H_S, pressure)[0]
                lost = water_lost + steam_lost
                h_lost = (water_lost * rw_h + steam_lost * rs_h) / lost
                d_vwt, d_p, d_ar, d_vsd, level, _ = _derivatives(
                    vwt, pressure, ar, vsd, qf, qs, lost, h_lost, heat, hf, p)
                vwt = vwt + H * d_vwt
                pressure = pressure + H * d_p
                ar = np.clip(ar + H * d_ar, 0.002, 0.6)
                vsd = np.maximum(vsd + H * d_vsd, 0.0)
            # the gas side and the economiser on the 5-s grid
            mcp = gas_cp * fuel
            gas1 = t_air + (0.9 * released - heat) / mcp
            duty = p["eco"] * mcp * (gas1 - t_da[:, k])
            target = t_da[:, k] + duty / (4.3 * np.maximum(qf, 0.5))
            t_feed = k_eco * t_feed + (1 - k_eco) * target
            hf = _h_feed(t_feed)
            stack = gas1 - duty / mcp
            thermocouple = k_tc * thermocouple + (1 - k_tc) * stack
            if k >= WARMUP:
                i = k - WARMUP
                out["steam"][:, i] = steam_meter
                out["fuel"][:, i] = fuel
                out["feed"][:, i] = feed_meter
                out["pressure"][:, i] = pressure - 1.013
                out["level"][:, i] = seen
                out["t_feed"][:, i] = t_feed
                out["stack"][:, i] = thermocouple
        return {
            "steam_flow": quantise(3.6 * out["steam"] * (1.0 + batch.normal((n,), 0.005)), 0.01),
            "feedwater_temp": quantise(out["t_feed"] + batch.normal((n,), 0.2), 0.1),
            "fuel_flow": quantise(out["fuel"] * (1.0 + batch.normal((n,), 0.005)), 1.0),
            "feedwater_flow": quantise(3.6 * out["feed"] * (1.0 + batch.normal((n,), 0.005)),
                                       0.01),
            "drum_pressure": quantise(out["pressure"] + batch.normal((n,), 0.02), 0.01),
            "drum_level": quantise(out["level"] + batch.normal((n,), 3.0), 1.0),
            "flue_gas_temp": quantise(out["stack"] + batch.normal((n,), 1.0), 1.0)}


FAMILY = DrumBoiler()
