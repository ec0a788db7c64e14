"""The pyfunc model of a fit (loader module :mod:`registry.pyfunc`, no pickle).

Two places hold one, with the same layout (``MLmodel``, the environment files and
``data/signature/``, the signature bundle):

* a **baseline** fit gets an MLflow *logged model* linked to its run (:func:`log_logged_model`),
  its version's source;
* a **candidate** fit keeps the model in its own run's artifacts, under ``model/``
  (:meth:`PyfuncTemplate.write`), its version's source: the nightly path saves the
  four round trips of a logged model (create, upload, finalize, link) for every asset-night.
  Loading, verification and ``load_pyfunc`` read both the same way.
"""
from __future__ import annotations

import logging
import pathlib
import tempfile
import uuid

import pandas as pd
import yaml
from mlflow.entities import LoggedModelOutput, LoggedModelStatus
from mlflow.models import Model

from registry.store import naming
from registry.store.backend import Backend

logger = logging.getLogger(__name__)

BUNDLE_DIR = "signature"          # run artifact dir, and the pyfunc data dir's name
MODEL_DIR = "model"               # a candidate run's model, beside its bundle
MODEL_NAME = "pyfunc-model"       # logged model name (must differ from run artifact dirs)
LOADER_MODULE = "registry.pyfunc"


def pip_requirements() -> list[str]:
    """What the pyfunc model needs installed: this package, pinned to its version."""
    try:
        from importlib.metadata import version

        return [f"fleet-health=={version('fleet-health')}"]
    except Exception:
        return ["fleet-health"]


def save_pyfunc(path: pathlib.Path, bundle: pathlib.Path, description: Model) -> None:
    """``mlflow.pyfunc.save_model`` of the bundle in loader-module form."""
    import mlflow.pyfunc

    mlflow.pyfunc.save_model(str(path), loader_module=LOADER_MODULE, data_path=str(bundle),
                             mlflow_model=description, pip_requirements=pip_requirements())


class PyfuncTemplate:
    """Writes pyfunc model directories without running ``save_model`` for each one.

    ``save_model`` infers and writes the same environment files every time (about 7 ms);
    the template runs it once, keeps its files, and per model only copies the bundle and
    writes ``MLmodel`` with that model's ids, time and size.
    """

    def __init__(self):
        self._files: dict[str, bytes] | None = None
        self._mlmodel: dict | None = None

    def _prepare(self, bundle: pathlib.Path) -> None:
        with tempfile.TemporaryDirectory(prefix="fleet-health-template-") as scratch:
            path = pathlib.Path(scratch) / "model"
            save_pyfunc(path, bundle, Model())
            self._mlmodel = yaml.safe_load((path / "MLmodel").read_text())
            self._files = {p.name: p.read_bytes() for p in path.iterdir()
                           if p.is_file() and p.name != "MLmodel"}
        flavor = self._mlmodel["flavors"]["python_function"]
        if flavor.get("data") != f"data/{bundle.name}" or bundle.name != BUNDLE_DIR:
            raise AssertionError(f"unexpected pyfunc layout {flavor!r}")

    def write(self, path: pathlib.Path, bundle: pathlib.Path, run_id: str) -> None:
        """Write the model of the bundle ``bundle`` (a ``signature`` dir) into ``path``."""
        if self._files is None:
            self._prepare(bundle)
        data_dir = path / "data" / BUNDLE_DIR
        data_dir.mkdir(parents=True)
        size = 0
        for source in bundle.iterdir():     # the bundle's files (it has no sub-directory)
            content = source.read_bytes()
            (data_dir / source.name).write_bytes(content)
            size += len(content)
        for name, content in self._files.items():
            (path / name).write_bytes(content)
            size += len(content)
        mlmodel = dict(self._mlmodel, run_id=run_id, model_uuid=uuid.uuid4().hex,
                       model_id=None, model_size_bytes=size,
                       utc_time_created=str(pd.Timestamp.now(tz="UTC").tz_localize(None)))
        dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
        (path / "MLmodel").write_text(yaml.dump(mlmodel, Dumper=dumper, default_flow_style=False))


def log_logged_model(backend: Backend, experiment_id: str, run_id: str, asset_id: str,
                     bundle: pathlib.Path, path: pathlib.Path) -> str:
    """Log the bundle as a pyfunc LoggedModel linked to the run; returns its id.

    The steps of ``mlflow.pyfunc.log_model`` done with our own client, so that no global
    tracking URI or active run is needed (and threads recording to different stores cannot
    mix them up).
    """
    client = backend.client
    logged = client.create_logged_model(
        experiment_id, name=MODEL_NAME, source_run_id=run_id,
        tags={naming.TAG_ASSET_ID: asset_id}, model_type="fleet-health-signature")
    try:
        description = Model(artifact_path=logged.artifact_location, model_uuid=logged.model_id,
                            run_id=run_id, model_id=logged.model_id)
        save_pyfunc(path, bundle, description)
        backend.log_artifacts(logged.artifact_location, str(path))
        client.finalize_logged_model(logged.model_id, LoggedModelStatus.READY)
        client.log_outputs(run_id, [LoggedModelOutput(logged.model_id, step=0)])
    except BaseException:
        try:
            client.finalize_logged_model(logged.model_id, LoggedModelStatus.FAILED)
        except Exception:
            logger.exception("could not mark logged model %s as failed", logged.model_id)
        raise
    return logged.model_id


def model_source(backend: Backend, run, model_id: str) -> str:
    """Where a recorded fit's model lives: its logged model, else its run's ``model/``."""
    if model_id:
        return backend.client.get_logged_model(model_id).artifact_location
    return f"{run.info.artifact_uri.rstrip('/')}/{MODEL_DIR}"
