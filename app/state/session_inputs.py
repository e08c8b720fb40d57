"""The session's own inputs, declared once: the model (α, β or w, σ, m; :ref:`model-equations`), the ISL filter's ν
(A.17), the noise seed and the horizon ``T = horizon / r_min`` (A.24), and how the page shows the run (view, tab,
presenter mode). Their ranges, symbols and explanations are the core's table of bounds (:data:`isl_core.BOUNDS`);
:class:`app.state.AppState` is built on them. Each declaration is the input's check: param refuses a bad value when it
is assigned (:mod:`app.inputs`)."""

from __future__ import annotations

import param

from isl_core import BOUNDS

from ..inputs import Real, Whole
from ..text import R_MIN

__all__ = ["DISPLAY_INPUTS", "INPUTS", "TABS", "VIEWS", "SessionInputs"]

INPUTS = ("alpha", "beta_from_w", "w", "beta", "sigma", "nu", "m", "seed", "horizon")  #: the model's and the run's
#: how the page shows the run, kept in the link like the inputs (a shared link, presenter mode's reload); no new run
DISPLAY_INPUTS = ("view", "tab", "present")
VIEWS = ("signal", "errors")  #: the trajectories' two views: the signal and its estimates, or each filter's error
TABS = ("trajectories", "sweep", "worstcase", "compare", "scenarios", "data")  #: the page's tabs, in order


class SessionInputs(param.Parameterized):
    """The inputs of a session's run and of its display (the module docstring)."""

    alpha = Real(0.5, bounds=BOUNDS.alpha.range, label=BOUNDS.alpha.symbol, doc=BOUNDS.alpha.doc)
    beta_from_w = param.Boolean(
        True,
        label="β from w",
        doc=("Paper A's parametrization (A.25): β = w·√(2α), w = stationary std of Xₘ. Off: β is set directly."),
    )
    w = Real(3.0, bounds=BOUNDS.w.range, label=BOUNDS.w.symbol, doc=BOUNDS.w.doc)
    beta = Real(3.0, bounds=BOUNDS.beta.range, label=BOUNDS.beta.symbol, doc=BOUNDS.beta.doc)
    sigma = Real(20.0, bounds=BOUNDS.sigma.range, label=BOUNDS.sigma.symbol, doc=BOUNDS.sigma.doc)
    nu = Real(3.0, bounds=BOUNDS.nu.range, label=BOUNDS.nu.symbol, doc=BOUNDS.nu.doc)
    m = Whole(3, bounds=BOUNDS.m.range, label=BOUNDS.m.symbol, doc=BOUNDS.m.doc)
    seed = Whole(1, bounds=BOUNDS.seed.range, label=BOUNDS.seed.symbol, doc=BOUNDS.seed.doc)
    horizon = Real(
        10.0,
        bounds=BOUNDS.horizon.range,
        label=f"horizon (× 1/{R_MIN})",
        doc=BOUNDS.horizon.doc.replace("r_min", R_MIN),
    )
    view = param.Selector(
        objects=list(VIEWS),
        default="signal",
        label="trajectory view",
        doc="The trajectory plots draw the signal and its estimates, or each filter's error.",
    )
    tab = param.Selector(objects=list(TABS), default="trajectories", label="open tab", doc="The tab on screen.")
    present = param.Boolean(False, label="presenter mode", doc="Larger text for a projector, the controls folded away.")
