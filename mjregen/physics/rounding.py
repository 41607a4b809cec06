"""Numbers as MJCF writes them, so that an exported model reproduces the compiled one."""

from __future__ import annotations

from typing import Sequence

import numpy as np


def round_like_mjcf(values: float | Sequence[float] | np.ndarray) -> float | list[float]:
    """`values` rounded to the 6 significant digits that MJCF export writes.

    Every number the model gets passes through here, so the exported XML reproduces the
    compiled model bit for bit.
    """
    if np.ndim(values) == 0:
        return float(f"{float(values):.6g}")
    return [float(f"{float(v):.6g}") for v in values]
