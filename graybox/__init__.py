"""graybox: the gray-box method of model-based fault diagnosis (pure science core).

No MLflow, no Prefect: this package only needs numpy, scipy, pandas, pyarrow and torch.
"""
from graybox.exceptions import (ArtifactError, GrayBoxError, InsufficientDataError,
                                InvalidAssetIdError, ModelSpecError, StructureMismatchError,
                                TelemetryError)
from graybox.models import WhiteBoxModel, load_model
from graybox.residual import residual_frame

__all__ = ["GrayBoxError", "ModelSpecError", "TelemetryError", "InsufficientDataError",
           "StructureMismatchError", "ArtifactError", "InvalidAssetIdError",
           "WhiteBoxModel", "load_model", "residual_frame"]
