"""The session's own inputs, declared once: the model (α, β or w, σ, m; :ref:`model-equations`), the ISL filter's ν
(A.17), the noise seed and the horizon ``T = horizon / r_min`` (A.24), and how the page shows the run (view, tab,
presenter mode). :class:`app.state.AppState` is built on them; every assignment is checked there."""

from __future__ import annotations

import param

from ..pipeline import HORIZON_BOUNDS
from ..text import R_MIN

__all__ = ["DISPLAY_INPUTS", "INPUTS", "TABS", "VIEWS", "SessionInputs"]

INPUTS = ("alpha", "beta_from_w", "w", "beta", "sigma", "nu", "m", "seed", "horizon")  #: the model's and the run's
#: how the page shows the run, kept in the link like the inputs (a shared link, presenter mode's reload); no new run
DISPLAY_INPUTS = ("view", "tab", "present")
VIEWS = ("signal", "errors")  #: the trajectories' two views: the signal and its estimates, or each filter's error
TABS = ("trajectories", "sweep", "worstcase", "compare", "scenarios", "data")  #: the page's tabs, in order


class SessionInputs(param.Parameterized):
    """The inputs of a session's run and of its display (the module docstring)."""

    alpha = param.Number(
        0.5,
        bounds=(0.0, 100.0),
        label="α",
        doc=("Damping of the top derivative Xₘ, dXₘ = −α Xₘ dt + β dv (A.5); α = 0 is paper B's white-noise model."),
    )
    beta_from_w = param.Boolean(
        True,
        label="β from w",
        doc=("Paper A's parametrization (A.25): β = w·√(2α), w = stationary std of Xₘ. Off: β is set directly."),
    )
    w = param.Number(
        3.0,
        bounds=(0.01, 100.0),
        label="w",
        doc=("Stationary standard deviation of Xₘ (A.25); used when 'β from w' is on. Paper A: w = 3."),
    )
    beta = param.Number(
        3.0,
        bounds=(0.01, 1000.0),
        label="β",
        doc=("Intensity of the noise driving Xₘ (A.5); used when 'β from w' is off."),
    )
    sigma = param.Number(
        20.0,
        bounds=(0.1, 1000.0),
        label="σ",
        doc=("Observation noise intensity, dY = X₁ dt + σ dε (A.6). Known to the Kalman–Bucy filter only."),
    )
    nu = param.Number(
        3.0,
        bounds=(0.001, 10000.0),
        label="ν",
        doc=("The ISL filter's only tuning knob (A.17); paper A studies ν/β = 2^ℓ, ℓ = −8..2."),
    )
    m = param.Integer(3, bounds=(1, 6), label="m", doc="State dimension: X₁ and its m − 1 derivatives (A.1).")
    seed = param.Integer(1, bounds=(0, 2**31 - 1), label="seed", doc="Seed of the noise: same seed, same run.")
    horizon = param.Number(
        10.0,
        bounds=HORIZON_BOUNDS,
        label=f"horizon (× 1/{R_MIN})",
        doc=(f"Simulated time T in units of the optimal filter's settling time 1/{R_MIN} (A.24); paper A, Fig. 3: 10."),
    )
    view = param.Selector(
        objects=list(VIEWS),
        default="signal",
        label="trajectory view",
        doc="The trajectory plots draw the signal and its estimates, or each filter's error.",
    )
    tab = param.Selector(objects=list(TABS), default="trajectories", label="open tab", doc="The tab on screen.")
    present = param.Boolean(False, label="presenter mode", doc="Larger text for a projector, the controls folded away.")
