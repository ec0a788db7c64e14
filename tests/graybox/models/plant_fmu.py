"""The test FMU: fmu_plant/plant.c (a heater and a probe, both hidden, one input, one computed
output, a tunable and a fixed parameter) compiled with the system's C compiler against the
FMI 2.0 headers FMPy ships and zipped with fmu_plant/modelDescription.xml; the same plant
written in Python; and its exact response to a power profile.

Shared by test_fmu.py, bench_fmu.py and the flow tests' FMU fleet
(tests/flows/test_fmu_fleet.py, which loads this file by its path)."""
from __future__ import annotations

import pathlib
import shutil
import subprocess
import zipfile

import fmpy   # the test extra installs it: its absence is a failure, not a skip
import numpy as np
import pandas as pd
import pytest

from graybox.models.base import WhiteBoxModel

SOURCES = pathlib.Path(__file__).parent / "fmu_plant"
DESCRIPTION = (SOURCES / "modelDescription.xml").read_text()
GUID = "{8c4e810f-3df3-4a00-8276-176fa3c9128f}"   # plant.c's and DESCRIPTION's
COMPILER = shutil.which("cc")
needs_compiler = pytest.mark.skipif(COMPILER is None, reason="no C compiler (cc) to build the "
                                                             "test FMU")
DT = 1.0


class TwinPlant(WhiteBoxModel):
    """The FMU's plant written in Python (plant.c's equations)."""

    states = ("heater_T", "probe_T")
    inputs = ("power",)
    outputs = ("reading",)
    default_parameters = {"tau": 20.0, "lag": 5.0}

    def derivatives(self, x, u):
        p = self.parameters
        heater, probe = x[..., 0], x[..., 1]
        return np.stack([(0.05 * u[..., 0] - heater) / p["tau"], (heater - probe) / p["lag"]],
                        axis=-1)

    def output(self, x, u):
        return x[..., 1:2] + 0.2 * x[..., 0:1]

    def matrices(self):
        """``A``, ``B``, ``C`` of the linear plant."""
        p = self.parameters
        a = np.array([[-1 / p["tau"], 0.0], [1 / p["lag"], -1 / p["lag"]]])
        return a, np.array([[0.05 / p["tau"]], [0.0]]), np.array([[0.2, 1.0]])


def build_fmu(directory: pathlib.Path, description: str = DESCRIPTION,
              binary: str = "binaries/linux64/plant.so",
              guid: str | None = None) -> pathlib.Path:
    """plant.c compiled and zipped with ``description`` as ``directory/plant.fmu``;
    ``guid``: a re-export under another GUID (the binary's and the description's)."""
    directory.mkdir(parents=True, exist_ok=True)
    library = directory / "plant.so"
    headers = pathlib.Path(fmpy.__file__).parent / "c-code"
    defines = []
    if guid is not None:
        description = description.replace(GUID, guid)
        defines = [f'-DGUID="{guid}"']
    subprocess.run([COMPILER, "-shared", "-fPIC", "-O2", *defines, "-I", str(headers), "-o",
                    str(library), str(SOURCES / "plant.c"), "-lm"], check=True)
    path = directory / "plant.fmu"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("modelDescription.xml", description)
        archive.write(library, binary)
    return path


def simulate(n: int, seed: int, start, noise: float, tau: float = 20.0,
             changed: tuple[int, float] | None = None):
    """The plant's exact response to held power levels with ramps, the power linear between
    samples (the augmented system ``[x, u, delta u]`` through the matrix exponential), and
    its reading with white measurement noise; no process noise. ``changed``: ``(k, tau)``,
    the heater's time constant from sample ``k`` on (a fault)."""
    from scipy.linalg import expm

    def step_of(time_constant: float) -> np.ndarray:
        a, b, _ = TwinPlant({"tau": time_constant}).matrices()
        augmented = np.zeros((4, 4))
        augmented[:2, :2], augmented[:2, 2:3], augmented[2, 3] = a, b, 1.0 / DT
        return expm(augmented * DT)[:2]

    c = TwinPlant().matrices()[2]
    before = step_of(tau)
    after = before if changed is None else step_of(changed[1])
    change_at = n if changed is None else changed[0]
    rng = np.random.default_rng(seed)
    levels = np.repeat(rng.uniform(0.0, 200.0, n // 90 + 1), 90)[:n]
    power = np.convolve(levels, np.ones(15) / 15, mode="same")
    x = np.empty((n, 2))
    x[0] = start
    for k in range(1, n):
        step = before if k <= change_at else after
        x[k] = step @ np.array([*x[k - 1], power[k - 1], power[k] - power[k - 1]])
    index = pd.date_range("2026-01-01", periods=n, freq="1s", tz="UTC") + pd.Timedelta(days=seed)
    frame = pd.DataFrame({"reading": (x @ c.T)[:, 0] + rng.normal(0.0, noise, n),
                          "power": power}, index=index)
    return frame, x
