"""The one-degree phi_F grid on which the metric, verdict and diagnosis tests build curves."""

from __future__ import annotations

import numpy as np

#: Samples per revolution (one a degree).
N = 360
#: The grid over one revolution without its repeated end sample, rad.
PHI = np.arange(N) * 2.0 * np.pi / N
