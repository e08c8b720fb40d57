"""Export of a run as CSV text (the dashboard's download button)."""
from __future__ import annotations

import io

import numpy as np

from isl_core import Run

__all__ = ["run_csv"]


def run_csv(run: Run | None) -> str:
    """``t, X1..Xm, Xhat1..Xhatm, Xcheck1..Xcheckm`` rows (N+1 of them) under a ``#`` header with the parameters.

    X is the truth, Xhat the Kalman–Bucy estimate X̂, Xcheck the ISL estimate X̌; 9 significant digits.
    """
    if run is None:
        return "# no run\n"
    mo, m = run.model, run.model.m
    cols = ["t", *(f"{name}{i}" for name in ("X", "Xhat", "Xcheck") for i in range(1, m + 1))]
    head = (f"isl run: alpha={mo.alpha:.17g} beta={mo.beta:.17g} sigma={mo.sigma:.17g} m={m} "
            f"nu={run.nu:.17g} seed={run.seed} T={run.T:.17g} h={run.h:.17g} N={run.N}\n" + ",".join(cols))
    out = io.StringIO()
    np.savetxt(out, np.column_stack([run.t, run.X, run.X_hat, run.X_check]), delimiter=",", header=head,
               comments="# ", fmt="%.9g")
    return out.getvalue()
