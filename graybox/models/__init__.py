"""Physics-model plugins: the white boxes used to filter telemetry into residuals."""
from graybox.models.base import WhiteBoxModel, load_model
from graybox.models.gas_turbine import GasTurbineShaft, LangevinShaft
from graybox.models.linear import DriveTrain, LinearStateSpace, PumpLoop, linear_parameters
from graybox.models.spec import ModelSpec

__all__ = ["WhiteBoxModel", "load_model", "ModelSpec", "GasTurbineShaft", "LangevinShaft",
           "LinearStateSpace", "DriveTrain", "PumpLoop", "linear_parameters"]
