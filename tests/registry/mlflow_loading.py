"""MLflow's own loader of a registered model, as a user outside the registry would call it."""
from __future__ import annotations

import mlflow


def load_by_models_uri(tracking_uri: str, models_uri: str):
    """``mlflow.pyfunc.load_model(models_uri)`` (``models:/<name>/<version or @alias>``) with
    ``tracking_uri`` as MLflow's tracking and registry server; MLflow's global URIs are put
    back afterwards."""
    previous = mlflow.get_tracking_uri(), mlflow.get_registry_uri()
    mlflow.set_tracking_uri(tracking_uri)
    mlflow.set_registry_uri(tracking_uri)
    try:
        return mlflow.pyfunc.load_model(models_uri)
    finally:
        mlflow.set_tracking_uri(previous[0])
        mlflow.set_registry_uri(previous[1])
