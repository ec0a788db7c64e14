"""The SKAB benchmark's smoke run (issue 20): two experiments through the product's own
command line (import, baseline fit, reanalyze), every baseline fitting and each experiment
scored by the gray box and the comparison detectors (PCA T2+Q, Isolation forest, the project's
classic detectors).

Reads the GPL-3.0 data from ``../shared/datasets/skab`` beside the repository (never copied
into it); skipped when that folder is absent.
"""
from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys

import pytest

from benchmarks.skab.data import dataset_dir

REPO_ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = dataset_dir(REPO_ROOT)
pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not (DATA / "data" / "anomaly-free").is_dir(),
                                 reason=f"SKAB data (GPL-3.0, not in the repository) absent "
                                        f"at {DATA}")]


def test_two_experiments_are_baselined_reanalysed_and_scored(tmp_path):
    env = dict(os.environ, PREFECT_HOME=str(tmp_path / ".prefect"),
               PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS="180",
               PYTHONPATH=str(REPO_ROOT))
    env.pop("PREFECT_API_URL", None)
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.skab", "--experiments", "other/5,valve1/4",
         "--workdir", str(tmp_path / "work"), "--json", str(tmp_path / "skab.json")],
        cwd=REPO_ROOT, env=env, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    results = json.loads((tmp_path / "skab.json").read_text())
    assert results["not_baselined"] == {}
    # each experiment scored by every detector, on the windows the gray box analysed
    for detector in ("gray_box", "pca_t2q", "iforest", "classic_cusum_mean", "classic_glr"):
        scored = results["experiments"][detector]
        assert [s["experiment"] for s in scored] == ["other/5", "valve1/4"]
        assert all(s["fault_windows"] >= 2 and s["healthy_windows"] >= 1 for s in scored)
    # other/5's fault (vibration up 2.5-fold) is caught by the gray box's vibration tiers
    other = [w for w in results["windows"] if w["experiment"] == "other/5"
             and w["label"] == "fault" and w["gray_box"] is not None]
    assert other and all(w["gray_box"] for w in other)
    assert any(t.endswith("vibration_1") for w in other for t in w["tiers"])
    # the Markdown report names the detectors
    assert "| gray_box |" in done.stdout and "| pca_t2q |" in done.stdout
