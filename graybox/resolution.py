"""The resolution of a quantized reading: the step its logger writes values in."""
from __future__ import annotations

import numpy as np

#: a reading is quantized when at least this share of its values lies on its step's grid (a
#: few interpolated samples, where the grid filled a gap, do not)
ON_GRID_SHARE = 0.99
#: how close to the step's grid a value must lie, in steps (float rounding of decimals)
GRID_TOLERANCE = 0.01
#: the step is a change at least this share of the changes are
COMMON_SHARE = 0.01
#: significant digits of the values that changes are compared at
SIGNIFICANT_DIGITS = 10


def reading_resolution(values: np.ndarray) -> float:
    """The step of a quantized reading; 0 for a reading that is not quantized.

    The step is the smallest change between consecutive samples that makes up at least
    :data:`COMMON_SHARE` of the non-zero changes (a few interpolated samples, where the grid
    filled a gap, change by less and are rare). The reading is quantized in it when
    :data:`ON_GRID_SHARE` of its values are whole multiples of the step away from its
    smallest value (within :data:`GRID_TOLERANCE` of a step): a temperature logged to 0.01
    degree, a level to 1 cm. A sensor whose noise the logger keeps in full has changes of
    every size, none of them common.

    Parameters
    ----------
    values : ndarray of shape (N,)
        One channel's samples in time order; non-finite ones are ignored.

    Returns
    -------
    float
    """
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    changes = np.abs(np.diff(values))
    changes = changes[changes > 0]
    if not changes.size:
        return 0.0
    # decimals written by a logger differ in their last bits once differenced
    digits = SIGNIFICANT_DIGITS - int(np.floor(np.log10(np.abs(values).max())))
    sizes, counts = np.unique(np.round(changes, digits), return_counts=True)
    common = sizes[counts >= COMMON_SHARE * changes.size]
    if not common.size:
        return 0.0
    step = float(common.min())
    if step == 0.0:
        # changes below the values' significant digits are common (a wide reading's offset
        # against its variation): no logger's grid
        return 0.0
    multiples = (values - values.min()) / step
    on_grid = np.abs(multiples - np.round(multiples)) <= GRID_TOLERANCE
    return step if on_grid.mean() >= ON_GRID_SHARE else 0.0
