"""Small shared builders for graybox tests (records made by hand, no fitting)."""
import numpy as np
import pandas as pd
import pytest

from graybox.linear_tier import LinearTier
from graybox.models.spec import ModelSpec
from graybox.noise_tier import NoiseTier
from graybox.nonlinear_tier import NonlinearTier
from graybox.settings import GrayBoxSettings
from graybox.signature import ChannelSignature, ChannelStructure, Selection, Signature


def raw_frame(**channels) -> pd.DataFrame:
    """Raw rows of ``channels`` every 10 s from 2026-01-04, tagged with file and row."""
    n = len(next(iter(channels.values())))
    frame = pd.DataFrame({"timestamp": pd.date_range("2026-01-04", periods=n, freq="10s",
                                                     tz="UTC"), **channels})
    frame["_file"], frame["_row"] = "/t/part-0.parquet", np.arange(n)
    return frame


def make_channel(name="omega", a=(0.5, -0.2), w=None, W=None, moments=(0.0, 1.0, 0.0, 0.0),
                 n_samples=1000, selection=True):
    w = np.full((2, 3), 0.1) if w is None else np.asarray(w, float)
    W = np.array([0.3, -0.4]) if W is None else np.asarray(W, float)
    structure = ChannelStructure(period=0, seasonal_order=0, diff_order=1, ar_order=len(a),
                                 center=0.0, scale=2.0, tau=1, embedding_dim=w.shape[1],
                                 hidden_units=w.shape[0], nn_scale=4.0, nonlinear_needed=False,
                                 init_seed=7)
    return ChannelSignature(
        name, structure, LinearTier(tuple(a), 1.0, tuple([0.01] * len(a)), n_samples),
        NonlinearTier.from_arrays(w, W, 0.05, 0.001 if selection else None, 12),
        NoiseTier(*moments, 20.0, 0.4, 20, n_samples), n_samples,
        Selection(3.0, 30.0, -12.0, 0, "bic") if selection else None)


def make_signature(channels=None, **kwargs):
    channels = channels or (make_channel(),)
    fields = dict(model=ModelSpec("graybox.models.gas_turbine:LangevinShaft", {"gamma": 0.06},
                                  {"omega": "omega"}),
                  residual_method="one_step", sample_interval=10.0,
                  n_samples=channels[0].n_samples, settings=GrayBoxSettings(hidden_units=2),
                  asset_id="T-001", window_start="2026-01-01T00:00:00+00:00",
                  window_end="2026-01-02T00:00:00+00:00")
    fields.update(kwargs)
    return Signature(tuple(channels), **fields)


@pytest.fixture
def signature():
    return make_signature()
