"""``registry.load_mlflow``: MLflow's client and SQLAlchemy stores imported on request (a
served nightly run does it while it waits for its time), never by ``import registry``."""
import subprocess
import sys

STORES = ("mlflow.store.tracking.sqlalchemy_store", "mlflow.store.model_registry.sqlalchemy_store",
          "registry.registry")


def _loaded(code: str) -> list[bool]:
    probe = f"import sys; {code}; print([m in sys.modules for m in {STORES!r}])"
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          check=True)
    return [word == "True" for word in done.stdout.strip(" []\n").split(", ")]


def test_import_registry_loads_no_mlflow_and_load_mlflow_loads_the_stores():
    assert _loaded("import registry") == [False, False, False]
    assert _loaded("import registry; registry.load_mlflow()") == [True, True, True]
