"""Export of the run on screen as CSV (the dashboard's download button): everything needed to reuse or redo it.

The page holds a decimated copy of the run (:mod:`isl_core.runview`); the export simulates the same run again —
same inputs, same seed, hence the same trajectories bit for bit — keeping every step, or every k-th step when the
run has more than :data:`MAX_ROWS` (so a download stays a few MB; the header says which). The RMSE and ratios are
over every step, as on the page.

Layout: ``#`` lines first — the version and date, every input (with w, the horizon asked for and the horizon
simulated), the grid (h, N, T, the rows kept), the start, the averaging window, then per coordinate s_i (theory)
and every filter's measured ratio with its theory — then one row per kept step with named columns
``t, X1_position, …, reading, kbf_X1_position, …, isl_X1_position, …`` (X the signal, the reading, then each
filter's estimate). ``reading`` is what the filters took in: the observation's average over the interval since the
row before, (Y(t) − Y(t_prev))/(t − t_prev) (:func:`isl_core.simulate`'s readings; none, ``nan``, in the first row),
so that the file read back as a recorded series (:func:`isl_core.series.read_csv` with ``time="t"``,
``value="reading"``) is the run's own observation (:ref:`data-readings`).
"""

from __future__ import annotations

import datetime as _dt
import io
import math
from importlib.metadata import PackageNotFoundError, version

import numpy as np

from isl_core import Model, simulate
from isl_core.runview import TUBE_THEORY

from .pipeline import COORDINATES, extra_filters

__all__ = ["MAX_ROWS", "run_csv", "run_png"]

MAX_ROWS = 20_000  #: rows of a CSV at most (every k-th step beyond; a 20 000-row CSV at m = 6 is ≈ 10 MB)


def _version() -> str:
    try:
        return version("isl")
    except PackageNotFoundError:  # a source checkout that was not installed
        return "unknown"


def _header(state, req, run, view, prediction: dict) -> list[str]:
    m = req.m
    names = [f"X{i + 1}_{c}" for i, c in enumerate(_coordinates(m))]
    lines = [
        f"isl run export; isl {_version()}; {_dt.datetime.now(_dt.UTC).isoformat(timespec='seconds')}",
        f"model: m={m} alpha={req.alpha:.17g} beta={req.beta:.17g} sigma={req.sigma:.17g}"
        + (f" (beta = w*sqrt(2*alpha), w={state.w:.17g})" if state.beta_from_w else " (beta set directly)"),
        f"ISL filter: nu={req.nu:.17g} (nu/beta={req.nu / req.beta:.6g}); seed={req.seed}",
        f"horizon: asked {req.horizon:.17g}/r_min, simulated {run.horizon:.17g}/r_min (lengthened x{run.stretch:.6g});"
        f" r_min={run.r_min:.17g} T={run.T:.17g} h={run.h:.17g} N={run.N}",
        f"rows: every {run.every} step(s) ({len(run.t)} rows); the RMSE and ratios below are over all N steps",
        "reading: the observation's average over the interval since the row before, (Y(t) - Y(t_prev))/(t - t_prev),"
        " dY = X1 dt + sigma dW (none in the first row)",
        f"start: every filter at X(0) - e0, e0 ~ N(0, Delta) ({run.start}); averaging window t in [0, T], no burn-in",
        "other filters: "
        + (", ".join(f"{tr.name} = {tr.label}" for tr in run.tracks[2:]) or "none")
        + f"; sigma_design={req.sigma_design:.6g} sigma_range=[{req.sigma_range[0]:.6g}, {req.sigma_range[1]:.6g}]",
        "coordinate, s_i (theory), then per filter: measured RMSE ratio (theory ratio), share of time |e_i| <= 3 s_i"
        f" (theory {100 * TUBE_THEORY:.2f} % for the optimal filter)",
    ]
    for i in range(m):
        cells = []
        for tr, vtr in zip(run.tracks, view.tracks, strict=True):
            th = prediction.get(tr.name)
            theory = "n/a" if th is None or not math.isfinite(th[i]) else f"{th[i]:.6g}"
            cells.append(f"{tr.name} {tr.ratio[i]:.6g} ({theory}) {100 * vtr.inside[i]:.2f} %")
        lines.append(f"{names[i]}: s={run.s[i]:.9g}; " + "; ".join(cells))
    return lines


def _coordinates(m: int) -> tuple[str, ...]:
    return COORDINATES[:m]


def run_csv(state) -> str:
    """The run on screen in ``state`` (:class:`app.state.AppState`) as CSV text (module docstring)."""
    view = state.run
    if view is None:
        return "# no run to export\n"
    req = state.shown_request
    model = Model(req.alpha, req.beta, req.sigma, req.m)
    extra, every_spec = extra_filters(req, model)
    every = max(1, math.ceil((view.N + 1) / MAX_ROWS))
    run = simulate(
        model,
        req.nu,
        horizon=req.horizon,
        seed=req.seed,
        extra=extra,
        step_filters=every_spec,
        every=every,
        readings=True,
    )
    prediction = {"kbf": np.ones(req.m), "isl": state.prediction, **(state.extra_prediction or {})}
    coords = [f"X{i + 1}_{c}" for i, c in enumerate(_coordinates(req.m))]
    cols = ["t", *coords, "reading", *(f"{tr.name}_{c}" for tr in run.tracks for c in coords)]
    assert run.readings is not None  # asked for above
    data = np.column_stack([run.t, run.X, run.readings, *(tr.estimate for tr in run.tracks)])
    out = io.StringIO()
    head = "\n".join(_header(state, req, run, view, prediction)) + "\n" + ",".join(cols)
    np.savetxt(out, data, delimiter=",", header=head, comments="# ", fmt="%.9g")
    return out.getvalue()


def run_png(run) -> io.BytesIO:
    """``run`` (a :class:`isl_core.runview.RunView`) as a PNG figure — every coordinate, the legend, the parameters
    and the measured ratios — drawn by the renderer of ``isl figure3`` (:func:`app.static_figures.fig3_png`)."""
    from .static_figures import fig3_png

    out = io.BytesIO()
    ratios = "\n".join(
        f"{tr.label}: measured RMSE/s_i = " + ", ".join(f"{r:.3f}" for r in tr.ratio) for tr in run.tracks[:2]
    )
    fig3_png([run], out, note=f"{ratios}\n(this run, averaged over t in [0, T])")
    out.seek(0)
    return out
