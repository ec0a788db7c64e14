"""One asset-night read top to bottom: the project's frames from the nightly flow to the AR
fit, as docs/design.md 2.5 lists them (issue 21, item 1: at most about 8), and the baseline
flow's, which calibrates as it fits (two frames more)."""
from __future__ import annotations

import traceback

from flowtest_config import write_config
from flowtest_fleet import BASELINE_DAYS, day

#: the project's packages; Prefect's, MLflow's and the standard library's frames are not counted
PROJECT = ("flows", "registry", "graybox")


def project_frames(stack: traceback.StackSummary) -> list[str]:
    """``package/module.py:function`` of each frame of ``stack`` in the project's packages."""
    out = []
    for frame in stack:
        parts = frame.filename.replace("\\", "/").split("/")
        if "tests" in parts or "site-packages" in parts:
            continue
        at = max((i for i, part in enumerate(parts) if part in PROJECT), default=None)
        if at is not None:
            out.append(f"{'/'.join(parts[at:])}:{frame.name}")
    return out


def traced_fit_ar(monkeypatch) -> list[traceback.StackSummary]:
    """The stacks of every call of the linear tier's ``fit_ar`` from now on (its callers)."""
    import graybox.tiers.linear as linear

    stacks = []
    fit_ar = linear.fit_ar

    def traced(*args, **kwargs):
        stacks.append(traceback.extract_stack()[:-1])
        return fit_ar(*args, **kwargs)

    monkeypatch.setattr(linear, "fit_ar", traced)
    return stacks


def test_one_asset_night_from_the_flow_to_fit_ar_passes_eight_project_frames(workspace,
                                                                              monkeypatch):
    from flows.nightly import nightly

    stacks = traced_fit_ar(monkeypatch)
    state = nightly(config_path=str(workspace.config),
                    as_of=day(BASELINE_DAYS + 1).isoformat(), assets=["T-001"],
                    return_state=True)
    assert state.is_completed(), state.message
    assert project_frames(stacks[0]) + ["graybox/linear_tier.py:fit_ar"] == [
        "flows/nightly.py:nightly",
        "flows/batching.py:run_over_fleet",
        "flows/batching.py:run_batch",
        "flows/pipeline.py:execute",
        "graybox/signature_fit.py:fit_signatures",
        "graybox/signature_fit.py:_prepare",
        "graybox/tiers/linear.py:fit",
        "graybox/linear_tier.py:fit_ar",
    ]


def test_a_baseline_from_the_flow_to_fit_ar_passes_ten_project_frames(tmp_path, fleet, harness,
                                                                      monkeypatch):
    from flows.baseline import baseline

    stacks = traced_fit_ar(monkeypatch)
    config = write_config(tmp_path / "fleet.toml", fleet.root, tmp_path / "mlflow.db")
    state = baseline(start=day(0).isoformat(), end=day(BASELINE_DAYS).isoformat(),
                     config_path=str(config), assets=["T-001"], return_state=True)
    assert state.is_completed(), state.message
    # the baseline's own fit first; its leave-one-out refits and pieces follow, as deep
    assert {tuple(project_frames(stack)) for stack in stacks} == {tuple(project_frames(stacks[0]))}
    assert project_frames(stacks[0]) + ["graybox/linear_tier.py:fit_ar"] == [
        "flows/baseline.py:baseline",
        "flows/batching.py:run_over_fleet",
        "flows/batching.py:run_batch",
        "flows/pipeline.py:execute",
        "flows/pipeline.py:fit_baselines",
        "graybox/calibration.py:fit_baselines",
        "graybox/signature_fit.py:fit_signatures",
        "graybox/signature_fit.py:_prepare",
        "graybox/tiers/linear.py:fit",
        "graybox/linear_tier.py:fit_ar",
    ]
