"""The filters, by family: each a :class:`FilterSpec` that rides in the fused simulation with any other.

* :mod:`~isl_core.filters.base` — :class:`FilterSpec` and the kernels' codes of its kind (``KIND_*``);
* :mod:`~isl_core.filters.kalman` — the Kalman–Bucy filters: optimal (knows σ), mismatched, minimax (A.21–A.23);
* :mod:`~isl_core.filters.isl` — paper A's ISL filter (A.16–A.18) and the model-aware one;
* :mod:`~isl_core.filters.adaptive` — the Kalman–Bucy filter with σ estimated online (Mehra 1970);
* :mod:`~isl_core.filters.robust` — the same with Huber-clipped innovations;
* :mod:`~isl_core.filters.variational` — the variational-Bayes adaptive Kalman filter (Särkkä & Nummenmaa 2009);
* :mod:`~isl_core.filters.imm` — the interacting-multiple-model bank of Kalman filters (Blom & Bar-Shalom 1988);
* :mod:`~isl_core.filters.baselines` — the set a user who does not know σ compares, by stable name.
"""

from .adaptive import adaptive_kbf
from .base import (
    KIND_ADAPTIVE,
    KIND_CLAIRVOYANT,
    KIND_IMM,
    KIND_LINEAR,
    KIND_POWER,
    KIND_ROBUST,
    KIND_VB,
    AdaptiveGain,
    FilterSpec,
    IMMBank,
    VariationalGain,
    linearized_matrix,
)
from .baselines import BASELINES, LABELS, baseline_filters
from .imm import imm_kbf
from .isl import isl_filter, model_aware_isl
from .kalman import design_sigma, minimax_kbf, mismatched_kbf, optimal_kbf
from .robust import robust_kbf
from .variational import variational_kbf

__all__ = [
    "BASELINES",
    "KIND_ADAPTIVE",
    "KIND_CLAIRVOYANT",
    "KIND_IMM",
    "KIND_LINEAR",
    "KIND_POWER",
    "KIND_ROBUST",
    "KIND_VB",
    "LABELS",
    "AdaptiveGain",
    "FilterSpec",
    "IMMBank",
    "VariationalGain",
    "adaptive_kbf",
    "baseline_filters",
    "design_sigma",
    "imm_kbf",
    "isl_filter",
    "linearized_matrix",
    "minimax_kbf",
    "mismatched_kbf",
    "model_aware_isl",
    "optimal_kbf",
    "robust_kbf",
    "variational_kbf",
]
