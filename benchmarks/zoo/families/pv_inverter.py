"""A fleet of grid-tied commercial rooftop photovoltaic systems in South Africa, one 50-kW
three-phase string inverter per site, logged every 60 s by the site's data logger.

Written blind (the method's internals were not read to choose anything here). The sites and
the season: the zoo's day 0 is 5 January (southern summer), the days advance the sun's
declination and the equation of time from there. Each site is in one of three regions:
Gauteng's highveld (60 %: 25.5-26.5 S, 27.8-28.5 E, 1400-1700 m; warm days, afternoon
thunderstorms), Durban (15 %: 29.6-30.0 S, 30.8-31.1 E, sea level; humid, broken cloud and
overcast) and Cape Town (25 %: 33.7-34.1 S, 18.4-18.9 E, sea level; clear and windy). The
timestamps are UTC (SAST is UTC+2): solar noon is at 10:00-10:55 UTC, the sun is up from about
03:00 to 17:30 UTC, so a UTC day holds one whole production day.

True plant (10-s substeps, the logger's 60-s rows):

* **Sun and sky.** The sun's position from the declination, the equation of time, the site's
  longitude and latitude; the clear sky by Meinel's beam transmittance with altitude
  (``DNI = 1361 E0 [(1 - 0.14 h) 0.7^(AM^0.678) + 0.14 h]``, Kasten-Young air mass at the
  site's pressure, a hazy day up to 8 % less beam) and a clear-sky diffuse of 8-14 % of the
  extraterrestrial horizontal; plane of array by the isotropic sky and a ground albedo of
  0.2. Each site's array faces north (azimuth 0 +- 25 deg) at a tilt of 5-30 deg (a roof's
  pitch or a low rack).
* **Clouds** by the day's weather, drawn per region: clear; afternoon convection (clear
  morning, cumulus building from 10-13 h local to 40-80 % cover, on 60 % of such days a storm
  of 1-3 h from 14-17.5 h: a thick layer taking 78 % of the light at its densest, the ambient
  falling 4-8 K, gusts); broken cloud all day (30-70 % cover); overcast (a 50-85 % thick
  layer over 90 % cover). Whether a cloud hides the sun is a threshold on a cloud field (an
  Ornstein-Uhlenbeck sequence, 1-5 min correlation by the day) at the sky's cover, with a
  sharp edge (ramps of about 30 s); under a cloud 8 % of the beam passes, the diffuse grows
  with the cover (bright cloud sides: cloud enhancement above clear sky when the sun is out
  on a broken-cloud day).
* **The irradiance sensor**: a class-B thermopile pyranometer in the plane of the array at
  its upper edge (never shaded), its own calibration (+-1.5 %), cosine response, a night
  offset of about -2 W/m^2 under a clear sky, 1-min average, 1 W/m^2 resolution.
* **The array** sees the same sky a few metres away, averaged over its area (a 20-s lag),
  through its glass (ASHRAE incidence modifier, b0 = 0.05 on the beam; 0.95 on the
  diffuse), behind the roof's parapet: the beam is shaded at a sun elevation below 4-10 deg
  (per site, over a 4-deg partial band). 7-9 parallel strings (per site) of 18 modules of 450
  Wp (144 half-cell PERC, Vmp 41.5 V, Voc 49.5 V), so 56.7-72.9 kWp on the inverter's 50 kW
  (DC/AC 1.13-1.46), 1-6 years old (0.5 %/year), a rain-washed summer soiling of 0-1.5 % by
  the day.
* **Cell temperature**: one thermal node per m^2 (11-14 kJ/(m^2 K)) heated by 90 % of the
  irradiance less what is taken as electricity, cooled by a Faiman conductance ``U0 + U1 v``
  (U0 18-28 W/(m^2 K) by the mounting, U1 4-7 W/(m^3 s K)) to the ambient, and radiating 45
  W/m^2 to a clear sky (less under cloud): 5-8 min time constant. The logged module
  temperature is a PT1000 on a module's backsheet, 1-3 K per 1000 W/m^2 cooler than the cells.
* **DC power** at the maximum power point: ``P_stc G/1000 (1 + gamma (T_c - 25)) eta_rel(G)``,
  gamma -0.35..-0.37 %/K, a low-light efficiency ``1 + 0.012 ln(G/1000) - 0.004 ln^2`` (-3 %
  at 200 W/m^2), mismatch 1-2 %, the cables' ohmic loss 1.5 % at STC going as the current
  squared. The MPP voltage ``18 Vmp (1 - 0.0037 (T_c - 25)) (1 + 0.03 ln(G/1000))`` with a 0.5
  % tracker dither; the open-circuit voltage the same with Voc's -0.28 %/K and the cells' log
  term.
* **The inverter** (50 kW): losses ``0.25 % of rating + 1.0 % P + 1.0 % P^2/rating`` (the
  linear term 0.03 %/V higher above 600 V), so 96-97.8 % from 10 % load up; **clipping**: when
  the array could give more than the rating, the tracker moves off the MPP toward the
  open-circuit voltage (the P-V curve's right flank, ``P = Pmp (1 - ((V - Vmp)/(Voc -
  Vmp))^2.5)``), so the DC voltage rises while the AC holds 50 kW; a thermal **derating** of
  the limit from the heat sink at 75 C (+-2) down to 0 at 90 C. It connects when the array
  offers 0.15 kW for 60 s (the grid-code reconnection check) and disconnects below 0.08 kW;
  while disconnected in daylight the DC voltage is the array's open-circuit voltage and the
  powers are 0. On 6 % of days the grid fails for 2 h (a load-shedding slot at 8-16 h local;
  anti-islanding disconnects the inverter, then 60 s of checks).
* **Heat sink**: 35 kJ/K, cooled to the air beside the inverter (the ambient plus 0-6 K per
  1000 W/m^2 of sun on its enclosure) by 12 W/K of natural convection and up to 35 W/K more by
  its fan, whose speed the inverter raises from 0 at 45 C (+-2) to full at 60 C; the fan's 40 W
  at full speed come out of the AC. 25 K over the air at full power with the fan (12 min time
  constant); without it about 95 K, i.e. derating.
* **Weather**: the region's January climate (mean 20.5 / 25 / 21 C, +-2.5 C by the day, a
  daily swing of 9-12 / 5-7 / 8-10 K peaking at 15 h local, halved on overcast days, 0.4 K of
  30-min wander), wind 1.5-4 / 2-5 / 4-9 m/s by the day, gusty (1 min), stronger in the
  afternoon.

Telemetry at 60 s (the logger's rows: averages of the minute for irradiance, powers and DC
voltage, snapshots for temperatures), written day and night (the inverter's values 0 at
night, the logger keeps polling): ``irradiance`` (W/m^2, 1), ``ambient_temp`` (C, 0.1, 0.1 C
noise), ``module_temp`` (C, 0.1, 0.1 C noise), ``dc_power`` and ``ac_power`` (kW, 0.01; 0.3 % and
0.1 % noise), ``dc_voltage`` (V, 0.1, 0.5 V noise) and ``heatsink_temp`` (C, 1, 0.2 C noise:
inverters report whole degrees). The plant runs in daylight only, so the class declares
``running = { ac_power = [0.1, 1000] }`` (:data:`GRID`): rows with the inverter off are pauses.

The white box a user writes (:class:`PvInverterWhiteBox`) from the datasheets: module
temperature a first-order lag (7 min) to the NOCT rise (``T_a + (45 - 20)/800 G``; no wind,
no sky radiation, no back-sheet difference); DC power the nameplate's 60 kWp (the fleet's
standard 8 x 18 x 415 W design) linear in the measured irradiance with -0.39 %/K (no low-light
loss, no incidence angle, no shading, no cable loss); AC power a constant 97 % of it, clipped
at 50 kW by a ``min`` (no DC-voltage shift, no derating); DC voltage 720 V with -0.29 %/K (the
Voc coefficient; no irradiance term); heat sink one node (30 kJ/K, 40 W/K to the ambient: no
fan switching, no sun on the enclosure) heated by 3 % of the DC power. Parameters 10-20 %
off the fleet's.

Faults and why these magnitudes (fixed from the physics before any detection run):

* ``soiling``: the array's transmittance falls by m, built up linearly over 2 days from the
  onset (a dust episode in a dry spell, a building site next door, a bird colony on the
  roof), then held. 4 % is borderline: within two years' degradation and a dusty month, about
  what a cleaning pays for in a month on a 65-kWp roof; 12 % is a roof that needs washing now
  (about 1 MWh a month lost). Clipping hides part of it on a clear noon.
* ``string_outage``: m of the site's 7-9 parallel strings go open (a blown string fuse, a
  melted connector), from the onset: the DC current and power fall by m/N at the same
  voltage, the inverter's losses with it. 1 string is 11-14 % of the array (the classic
  fault nobody sees in the daily yield behind the weather; on a clear noon a clipping site
  loses nothing); 3 strings are 33-43 %, a site for a visit today.
* ``fan_failure``: the heat sink's fan delivers 1 - m of its airflow (m = 0.5: a worn bearing,
  a fan clogged with dust; m = 1: a dead fan). At full power on a bright afternoon the sink
  runs about 14 K hotter at 0.5 (to 65-75 C: touching the derating on the hottest days), and
  at 1 it heads for about 95 K over the air and derates the inverter (AC limited, DC voltage up):
  a warranty call.
* ``irradiance_sensor_drift``: the pyranometer reads low by m, reached linearly over 1 day
  from the onset (dust and droppings on its dome; the plant itself unchanged). 3 % is a class-B
  sensor's daily uncertainty, borderline; 10 % makes the site's performance ratio look 10 %
  better than it is and hides any real loss: the sensor must be cleaned.

The simulation costs about 3 s of CPU per batch of 128 asset-days (a 9000-step loop over
the batch): the full benchmark's 472 asset-days in about 10 s.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import lfilter
from scipy.special import ndtri

from benchmarks.zoo.family import (DayBatch, Family, FaultKind, SECONDS_PER_DAY, quantise,
                                   smooth_noise, spread)
from graybox.models.base import WhiteBoxModel

DT = 60.0
SUBSTEPS = 6
H = DT / SUBSTEPS
#: samples of warm-up: the hour before midnight UTC (dark)
WARMUP = 60
#: the zoo's day 0: 5 January
FIRST_DAY_OF_YEAR = 5
RATED_KW = 50.0
MODULES_PER_STRING = 18
MODULE_WP = 450.0
MODULE_VMP = 41.5
MODULE_VOC = 49.5
#: the class's grid: the logger writes the inverter's zeros at night; they are pauses
GRID = {"running": {"ac_power": [0.1, 1000.0]}}

#: per region: probability, latitude, longitude, altitude (km), climate mean (C), daily
#: swing (K), wind (m/s), and the day types' probabilities (clear, convective, broken,
#: overcast)
REGIONS = (
    (0.60, (-26.5, -25.5), (27.8, 28.5), (1.4, 1.7), 20.5, (9.0, 12.0), (1.5, 4.0),
     (0.25, 0.45, 0.15, 0.15)),
    (0.15, (-30.0, -29.6), (30.8, 31.1), (0.0, 0.1), 25.0, (5.0, 7.0), (2.0, 5.0),
     (0.20, 0.15, 0.40, 0.25)),
    (0.25, (-34.1, -33.7), (18.4, 18.9), (0.0, 0.1), 21.0, (8.0, 10.0), (4.0, 9.0),
     (0.65, 0.05, 0.20, 0.10)),
)


class PvInverterWhiteBox(WhiteBoxModel):
    """Module (back-sheet) and heat-sink temperatures (C) as states; DC power (kW) linear in
    the irradiance with a temperature coefficient, AC power (kW) a constant efficiency clipped
    at the rating, DC voltage (V) linear in the module temperature; inputs plane-of-array
    irradiance (W/m^2) and ambient temperature (C)."""

    states = ("module_temp", "heatsink_temp")
    outputs = ("module_temp", "dc_power", "ac_power", "dc_voltage", "heatsink_temp")
    inputs = ("irradiance", "ambient_temp")
    default_parameters = {"noct": 45.0, "module_lag": 420.0,
                          "p_stc": 60.0, "gamma": -0.0039,
                          "efficiency": 0.97, "ac_rating": 50.0,
                          "v_stc": 720.0, "beta": -0.0029,
                          "sink_capacity": 30.0, "sink_ua": 0.040}
    positive = ("noct", "module_lag", "p_stc", "efficiency", "ac_rating", "v_stc",
                "sink_capacity", "sink_ua")

    def _dc(self, x, u):
        p = self.parameters
        irradiance = np.maximum(u[..., 0], 0.0)
        return p["p_stc"] * irradiance / 1000.0 * (1.0 + p["gamma"] * (x[..., 0] - 25.0))

    def derivatives(self, x, u):
        p = self.parameters
        module, sink = x[..., 0], x[..., 1]
        irradiance, ambient = np.maximum(u[..., 0], 0.0), u[..., 1]
        target = ambient + (p["noct"] - 20.0) / 800.0 * irradiance
        loss = (1.0 - p["efficiency"]) * self._dc(x, u)                       # kW
        return np.stack([(target - module) / p["module_lag"],
                         (loss - p["sink_ua"] * (sink - ambient)) / p["sink_capacity"]],
                        axis=-1)

    def output(self, x, u):
        p = self.parameters
        dc = self._dc(x, u)
        ac = np.minimum(p["efficiency"] * dc, p["ac_rating"])
        voltage = p["v_stc"] * (1.0 + p["beta"] * (x[..., 0] - 25.0))
        return np.stack([x[..., 0], dc, ac, voltage, x[..., 1]], axis=-1)


def _sun(lat: np.ndarray, lon: np.ndarray, doy: np.ndarray, t: np.ndarray):
    """Per element (B,) and time (T,) seconds after midnight UTC: the sun's unit vector (east,
    north, up) components (B, T) each, and the local solar hour (B, T)."""
    declination = np.radians(23.44) * np.sin(2 * np.pi * (284.0 + doy) / 365.0)
    b = 2 * np.pi * (doy - 81.0) / 364.0
    eot = 9.87 * np.sin(2 * b) - 7.53 * np.cos(b) - 1.5 * np.sin(b)            # minutes
    solar = (t[None, :] / 3600.0 + lon[:, None] / 15.0 + eot[:, None] / 60.0)
    omega = np.radians(15.0 * (solar - 12.0))
    phi = np.radians(lat)[:, None]
    dec = declination[:, None]
    up = np.sin(phi) * np.sin(dec) + np.cos(phi) * np.cos(dec) * np.cos(omega)
    east = -np.cos(dec) * np.sin(omega)
    north = np.sin(dec) * np.cos(phi) - np.cos(dec) * np.sin(phi) * np.cos(omega)
    return east, north, up, solar % 24.0


def _sigmoid(x):
    return 1.0 / (1.0 + np.exp(-np.clip(x, -60.0, 60.0)))


class PvInverter(Family):
    name = "pv_inverter"
    title = "Grid-tied rooftop PV with a 50-kW string inverter, South African summer (60 s)"
    description = ("clear sky with sun path per site, day types with convective storms and "
                   "broken-cloud ramps, pyranometer vs array (incidence, parapet shading, "
                   "spatial lag), Faiman cell temperature with wind, low-light loss, inverter "
                   "efficiency curve with clipping off the MPP and thermal derating, fan-"
                   "cooled heat sink, load-shedding outages; white box: NOCT lag, linear DC "
                   "with a temperature coefficient, min() clipping, one heat-sink node, "
                   "10-20 % off")
    spec = "benchmarks.zoo.families.pv_inverter:PvInverterWhiteBox"
    columns = {"irradiance": "irradiance", "ambient_temp": "ambient_temp",
               "module_temp": "module_temp", "dc_power": "dc_power", "ac_power": "ac_power",
               "dc_voltage": "dc_voltage", "heatsink_temp": "heatsink_temp"}
    sample_interval = DT
    grid = GRID
    held_out = True
    channels = ("irradiance", "ambient_temp", "module_temp", "dc_power", "ac_power",
                "dc_voltage", "heatsink_temp")
    faults = (
        FaultKind("soiling", "the array's transmittance down by m, built up linearly over 2 "
                  "days from the onset (relative)", (0.04, 0.12)),
        FaultKind("string_outage", "m of the site's 7-9 parallel strings open (DC current "
                  "down by m/N)", (1.0, 3.0)),
        FaultKind("fan_failure", "the heat sink's fan delivers 1 - m of its airflow",
                  (0.5, 1.0)),
        FaultKind("irradiance_sensor_drift", "the pyranometer reads low by m, reached "
                  "linearly over 1 day (relative)", (0.03, 0.10)),
    )

    def true_parameters(self, rng):
        u = rng.uniform()
        cumulative = np.cumsum([r[0] for r in REGIONS])
        region = int(np.searchsorted(cumulative, u * cumulative[-1]))
        _, lat, lon, alt, climate, swing, wind, types = REGIONS[region]
        return {"region": float(region),
                "lat": float(rng.uniform(*lat)), "lon": float(rng.uniform(*lon)),
                "altitude": float(rng.uniform(*alt)), "climate": climate,
                "swing_low": swing[0], "swing_high": swing[1],
                "wind_low": wind[0], "wind_high": wind[1],
                "p_clear": types[0], "p_convective": types[1], "p_broken": types[2],
                "tilt": float(rng.uniform(5.0, 30.0)),
                "azimuth": float(rng.uniform(-25.0, 25.0)),
                "parapet": float(rng.uniform(4.0, 10.0)),
                "strings": float(rng.integers(7, 10)),
                "age": float(rng.uniform(1.0, 6.0)),
                "gamma": float(rng.uniform(-0.0037, -0.0035)),
                "mismatch": float(rng.uniform(0.01, 0.02)),
                "u0": float(rng.uniform(18.0, 28.0)), "u1": float(rng.uniform(4.0, 7.0)),
                "module_capacity": float(rng.uniform(11e3, 14e3)),
                "back_delta": float(rng.uniform(1.0, 3.0)),
                "sensor_gain": spread(rng, 1.0, 0.015),
                "derate_start": spread(rng, 75.0, 0.027),
                "fan_start": spread(rng, 45.0, 0.044),
                "enclosure_sun": float(rng.uniform(0.0, 6.0))}

    def simulate_days(self, batch: DayBatch) -> dict[str, np.ndarray]:
        p = batch.true
        size = len(batch)
        n, t, hour, total = self.clock(WARMUP)
        _, ts, _, steps = self.clock(WARMUP, SUBSTEPS)
        doy = FIRST_DAY_OF_YEAR + batch.day.astype(float)
        # -- the sun, the clear sky, the array's geometry (10-s grid) ------------------------
        east, north, up, solar = _sun(p["lat"], p["lon"], doy, ts)
        cos_z = np.clip(up, 0.0, 1.0)
        elevation = np.degrees(np.arcsin(np.clip(up, -1.0, 1.0)))
        zenith = 90.0 - np.maximum(elevation, 0.0)
        air_mass = np.exp(-p["altitude"] / 8.4)[:, None] / (
            cos_z + 0.50572 * (96.07995 - zenith) ** -1.6364)
        e0 = 1.0 + 0.033 * np.cos(2 * np.pi * doy / 365.0)
        haze = batch.uniform(0.0, 1.0)
        h = p["altitude"][:, None]
        dni = (1361.0 * e0[:, None] * ((1 - 0.14 * h) * 0.7 ** (air_mass ** 0.678) + 0.14 * h)
               * (1.0 - 0.08 * haze[:, None])) * (up > 0)
        dhi = (0.08 + 0.06 * haze)[:, None] * 1361.0 * e0[:, None] * cos_z
        ghi = dni * cos_z + dhi
        tilt, azimuth = np.radians(p["tilt"])[:, None], np.radians(p["azimuth"])[:, None]
        cos_aoi = np.clip(np.sin(tilt) * np.sin(azimuth) * east + np.sin(tilt) * np.cos(azimuth)
                          * north + np.cos(tilt) * up, 0.0, 1.0) * (up > 0)
        beam = dni * cos_aoi
        sky = dhi * (1 + np.cos(tilt)) / 2 + 0.2 * ghi * (1 - np.cos(tilt)) / 2
        iam = np.clip(1.0 - 0.05 * (1.0 / np.maximum(cos_aoi, 0.05) - 1.0), 0.0, 1.0)
        shade = np.clip((elevation - (p["parapet"][:, None] - 4.0)) / 4.0, 0.0, 1.0)
        # -- the day's weather --------------------------------------------------------------
        draw = batch.uniform(0.0, 1.0)
        convective = (draw >= p["p_clear"]) & (draw < p["p_clear"] + p["p_convective"])
        broken = ((draw >= p["p_clear"] + p["p_convective"])
                  & (draw < p["p_clear"] + p["p_convective"] + p["p_broken"]))
        overcast = draw >= p["p_clear"] + p["p_convective"] + p["p_broken"]
        build = batch.uniform(10.0, 13.0)
        build_cover = batch.uniform(0.4, 0.8)
        storm_on = batch.uniform(0.0, 1.0) < 0.6
        storm_start = batch.uniform(14.0, 17.5)
        storm_length = batch.uniform(1.0, 3.0)
        broken_cover = batch.uniform(0.3, 0.7)
        layer = batch.uniform(0.5, 0.85)
        cloud_time = batch.uniform(60.0, 300.0)
        slow = smooth_noise(batch, steps, 3600.0 / H, 1.0)
        local = ((ts / 3600.0 + 2.0) % 24.0)[None, :]                    # SAST
        cover = np.full((size, steps), 0.02)
        cover = np.where(convective[:, None],
                         0.02 + build_cover[:, None] * _sigmoid((local - build[:, None]) / 0.7),
                         cover)
        cover = np.where(broken[:, None], broken_cover[:, None] + 0.15 * slow, cover)
        cover = np.where(overcast[:, None], 0.9, cover)
        cover = np.clip(cover, 0.01, 0.97)
        storm = (convective & storm_on)[:, None] * (
            _sigmoid((local - storm_start[:, None]) / 0.25)
            * _sigmoid((storm_start[:, None] + storm_length[:, None] - local) / 0.3))
        thick = np.where(overcast[:, None], np.clip(layer[:, None] + 0.1 * slow, 0.3, 0.95),
                         storm)
        # the cloud field: whether a cloud hides the sun (sharp edges), per element its own
        field = np.stack([_ou(rng, steps, tau / H) for rng, tau in zip(batch.rngs, cloud_time)])
        sun_out = _sigmoid((field - ndtri(cover)) / 0.12)
        transmitted = sun_out + (1.0 - sun_out) * 0.08
        brighten = 1.0 + 2.5 * cover * (1.0 - thick)
        dim = 1.0 - 0.78 * thick
        poa_sensor = (beam * transmitted + sky * brighten) * dim
        poa_array = (beam * transmitted * iam * shade + 0.95 * sky * brighten) * dim
        # -- ambient and wind ---------------------------------------------------------------
        mean = p["climate"] + batch.uniform(-2.5, 2.5)
        swing = batch.uniform(0.0, 1.0) * (p["swing_high"] - p["swing_low"]) + p["swing_low"]
        swing = swing * np.where(overcast, 0.5, 1.0)
        drop = batch.uniform(4.0, 8.0)
        ambient = (mean[:, None] + 0.5 * swing[:, None] * np.cos(2 * np.pi * (solar - 15.0) / 24.0)
                   + smooth_noise(batch, steps, 1800.0 / H, 0.4) - drop[:, None] * storm)
        wind_day = batch.uniform(0.0, 1.0) * (p["wind_high"] - p["wind_low"]) + p["wind_low"]
        wind = np.maximum(wind_day[:, None] * (1.0 + 0.3 * np.sin(np.pi * np.clip(
            (local - 9.0) / 12.0, 0.0, 1.0))) + smooth_noise(batch, steps, 60.0 / H, 0.8)
            + 5.0 * storm, 0.2)
        soil_day = 1.0 - batch.uniform(0.0, 0.015)
        outage = batch.uniform(0.0, 1.0) < 0.06
        outage_start = np.floor(batch.uniform(8.0, 16.0))
        grid_ok = ~(outage[:, None] & (local >= outage_start[:, None])
                    & (local < outage_start[:, None] + 2.0))
        dither = smooth_noise(batch, steps, 20.0 / H, 0.005)
        # -- faults -------------------------------------------------------------------------
        soiling = _ramp(batch, "soiling", ts, 2 * SECONDS_PER_DAY)
        strings_out = batch.active("string_outage", ts)
        fan_loss = batch.active("fan_failure", ts)
        sensor_loss = _ramp(batch, "irradiance_sensor_drift", ts, SECONDS_PER_DAY)
        # -- the array's constants ----------------------------------------------------------
        strings = p["strings"]
        p_stc = strings * MODULES_PER_STRING * MODULE_WP / 1000.0                 # kW
        area = p_stc / 0.206                                                      # m^2
        health = (1.0 - 0.005 * p["age"]) * (1.0 - p["mismatch"]) * soil_day
        # -- the loop -----------------------------------------------------------------------
        keep_array = np.exp(-H / 20.0)
        g_array = poa_array[:, 0].copy()
        cell = ambient[:, 0] - 1.5
        sink = ambient[:, 0].copy()
        ready = np.zeros(size)
        connected = np.zeros(size, dtype=bool)
        c_sink = 35.0                                                             # kJ/K
        outs = {k: np.zeros((size, steps)) for k in ("dc", "ac", "v", "cell", "sink", "g")}
        for s in range(steps):
            g_array = poa_array[:, s] + (g_array - poa_array[:, s]) * keep_array
            g = g_array * (1.0 - soiling[:, s])
            amb = ambient[:, s]
            log_g = np.log(np.maximum(g, 1.0) / 1000.0)
            rel = 1.0 + 0.012 * log_g - 0.004 * log_g ** 2
            warm = 1.0 + p["gamma"] * (cell - 25.0)
            working = (strings - strings_out[:, s]) / strings
            mpp = p_stc * g / 1000.0 * warm * np.maximum(rel, 0.0) * health * working
            mpp = mpp * (1.0 - 0.015 * (mpp / np.maximum(p_stc * working, 1e-9)))   # cables
            mpp = np.maximum(mpp, 0.0)
            v_mp = (MODULES_PER_STRING * MODULE_VMP * (1.0 - 0.0037 * (cell - 25.0))
                    * (1.0 + 0.03 * log_g))
            v_oc = (MODULES_PER_STRING * (MODULE_VOC * (1.0 - 0.0028 * (cell - 25.0))
                                          + 72 * 1.1 * 0.0257 * log_g))
            light = np.clip((g - 0.5) / 2.5, 0.0, 1.0)       # no voltage in the dark
            v_oc = np.maximum(v_oc, 0.0) * light
            v_mp = np.minimum(v_mp, 0.95 * v_oc)
            # the inverter's connection state machine
            offered = grid_ok[:, s] & (mpp > 0.15)
            ready = np.where(offered, ready + H, 0.0)
            connected = np.where(connected, grid_ok[:, s] & (mpp > 0.08), ready >= 60.0)
            # the limit: the rating, derated by the heat sink
            limit = RATED_KW * np.clip((90.0 - sink) / (90.0 - p["derate_start"]), 0.0, 1.0)
            p1 = 0.010 * (1.0 + 0.0003 * np.maximum(v_mp - 600.0, 0.0))
            p0, p2 = 0.0025 * RATED_KW, 0.010 / RATED_KW
            fan = np.clip((sink - p["fan_start"]) / 15.0, 0.0, 1.0)
            fan_kw = 0.04 * fan
            wanted = limit + fan_kw
            root = (1.0 - p1) ** 2 - 4.0 * p2 * (p0 + wanted)
            most = np.where(root > 0.0, ((1.0 - p1) - np.sqrt(np.maximum(root, 0.0)))
                            / (2.0 * p2), 0.0)
            dc = np.where(connected, np.minimum(mpp, most), 0.0)
            clipped = connected & (mpp > most)
            share = np.where(mpp > 0, 1.0 - dc / np.maximum(mpp, 1e-9), 0.0)
            v_clip = v_mp + (v_oc - v_mp) * np.clip(share, 0.0, 1.0) ** (1.0 / 2.5)
            voltage = np.where(connected, np.where(clipped, v_clip, v_mp) * (1.0 + dither[:, s]),
                               v_oc)
            loss = np.where(connected, p0 + p1 * dc + p2 * dc ** 2, 0.0)
            ac = np.where(connected, np.maximum(dc - loss - fan_kw, 0.0), 0.0)
            # cell temperature (per m^2), heat sink
            u_faiman = p["u0"] + p["u1"] * wind[:, s]
            taken = dc * 1000.0 / area / np.maximum(working, 1e-9)        # W/m^2 of a module
            radiated = 45.0 * (1.0 - cover[:, s]) * (1.0 - thick[:, s])
            steady = amb + (0.9 * g - taken - radiated) / u_faiman
            cell = steady + (cell - steady) * np.exp(-H * u_faiman / p["module_capacity"])
            air = amb + p["enclosure_sun"] * poa_sensor[:, s] / 1000.0
            conductance = 0.012 + 0.035 * fan * (1.0 - fan_loss[:, s])                 # kW/K
            sink_steady = air + loss / conductance
            sink = sink_steady + (sink - sink_steady) * np.exp(-H * conductance / c_sink)
            outs["dc"][:, s], outs["ac"][:, s], outs["v"][:, s] = dc, ac, voltage
            outs["cell"][:, s], outs["sink"][:, s], outs["g"][:, s] = cell, sink, g
        # -- the logger: minute averages and snapshots (the day only) ----------------------
        day = slice(WARMUP * SUBSTEPS, steps)

        def minute(values):
            return values[:, day].reshape(size, n, SUBSTEPS).mean(axis=2)

        def snapshot(values):
            return values[:, day][:, SUBSTEPS - 1::SUBSTEPS]

        reading = poa_sensor * p["sensor_gain"][:, None] * (1.0 - sensor_loss)
        night_offset = -2.0 * (1.0 - cover) * (poa_sensor < 5.0)
        irradiance = minute(reading + night_offset)
        back = snapshot(outs["cell"] - p["back_delta"][:, None] * outs["g"] / 1000.0)
        dc = minute(outs["dc"])
        ac = minute(outs["ac"])
        on = ac > 0.0
        return {
            "irradiance": quantise(irradiance + batch.normal((n,), 1.0)
                                   + 0.003 * irradiance * batch.normal((n,)), 1.0),
            "ambient_temp": quantise(snapshot(ambient) + batch.normal((n,), 0.1), 0.1),
            "module_temp": quantise(back + batch.normal((n,), 0.1), 0.1),
            "dc_power": quantise(np.maximum(dc * (1.0 + batch.normal((n,), 0.003)), 0.0)
                                 * (dc > 0), 0.01),
            "ac_power": quantise(np.maximum(ac * (1.0 + batch.normal((n,), 0.001)), 0.0) * on,
                                 0.01),
            "dc_voltage": quantise(np.maximum(minute(outs["v"]) + batch.normal((n,), 0.5)
                                              * (minute(outs["v"]) > 0), 0.0), 0.1),
            "heatsink_temp": quantise(snapshot(outs["sink"]) + batch.normal((n,), 0.2), 1.0)}


def _ou(rng: np.random.Generator, steps: int, correlation: float) -> np.ndarray:
    """A stationary unit-variance Ornstein-Uhlenbeck sequence of ``correlation`` steps."""
    a = np.exp(-1.0 / max(correlation, 1e-9))
    shocks = rng.normal(0.0, 1.0, steps) * np.sqrt(1 - a * a)
    return lfilter([1.0], [1.0, -a], shocks, zi=[a * rng.normal()])[0]


def _ramp(batch: DayBatch, kind: str, t: np.ndarray, duration: float) -> np.ndarray:
    """A fault of ``kind`` growing linearly from its onset to its magnitude over ``duration``
    seconds, then held: (B, len(t))."""
    mine = (batch.fault == kind)[:, None]
    elapsed = t[None, :] - batch.onset[:, None]
    grown = np.clip(np.where(mine, elapsed, -1.0) / duration, 0.0, 1.0)
    return np.where(mine & (elapsed >= 0), batch.magnitude[:, None] * grown, 0.0)


FAMILY = PvInverter()
