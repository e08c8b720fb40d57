"""The compiled kernels (numba): every loop over time steps, and nothing else.

* :mod:`~isl_core.kernels.euler` — paper A's constant-σ loop (:func:`advance`) and the display runs' min/max
  reduction (:func:`minmax_block`);
* :mod:`~isl_core.kernels.scenario` — the scenario loop (:func:`advance_scenario`): σ(t), the noise laws, the sensor
  interval, every filter family in lanes;
* :mod:`~isl_core.kernels.clairvoyant`, :mod:`~isl_core.kernels.imm`, :mod:`~isl_core.kernels.draws` — the
  clairvoyant recursion, the IMM bank and the noise draws the scenario loop runs in line;
* :mod:`~isl_core.kernels.common` — what both loops share (the power law's root, the adaptive gain's lookup);
* :mod:`~isl_core.kernels.cache` — how they are compiled and cached (:data:`CACHE`, :func:`sources_digest`).

Kernels trust their inputs: the public functions that call them validate (:mod:`isl_core.validate`).
"""

from .cache import CACHE, sources_digest
from .common import fast_cbrt
from .euler import advance, minmax_block
from .scenario import advance_scenario

__all__ = ["CACHE", "advance", "advance_scenario", "fast_cbrt", "minmax_block", "sources_digest"]
