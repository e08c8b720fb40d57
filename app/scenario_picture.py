"""The Scenario tab's picture: every filter against the clairvoyant reference, each at its knob by one tuning rule.

:func:`scenario_picture` runs :func:`isl_core.average_scenario` over the request's seeds (the seed input and the ones
after it) and returns, beside the runs:

* the **period statistic** (:meth:`isl_core.ScenarioAverage.periods`): per filter the normalized RMSE ratio to the
  clairvoyant filter over fixed periods — the first 1/r_min and 2/r_min after a change of σ, and the settled rest —
  pooled over the seeds, with Student's interval over them; the clairvoyant filter reads 1 within its interval;
* the **rolling ratio** (:meth:`isl_core.ScenarioAverage.rolling`), a picture in time: the worst coordinate per
  window, so it lies above 1 by its noise even for the reference (the plot says so);
* each filter's **tuning** and where it came from. The filters that do not know σ(t) — the model-aware ISL filter,
  the adaptive, variational-Bayes, robust and IMM filters, and paper A's ISL filter at its tuned ν — take the knobs
  of :func:`isl_core.scenario.tuning.tune` for the page's α, m and w when that tuning is cached (the minimax of the
  period statistic over the scenario table's presets, the same rule for every family), else those of the shipped
  tuning nearest the model (:func:`isl_core.shipped_tuning`, labelled as such), and run on the tuning's grid
  so that a memory of W readings spans what it spanned there. Without either (α = 0, an m the shipped grid lacks) they
  run at their constructors' defaults, and say "untuned". The page's own ISL filter runs at the ν input, as
  everywhere on the page.

Costs (:func:`costs`) are measured once per server and set of filters: nanoseconds a step of each filter beside the
loop's own three, on this server's CPU.
"""

from __future__ import annotations

import dataclasses
import io
import math
from dataclasses import dataclass

from isl_core import (
    Model,
    Rolling,
    Scenario,
    ScenarioAverage,
    ShippedTuning,
    adaptive_kbf,
    average_scenario,
    robust_kbf,
    shipped_tuning,
    variational_kbf,
    why_not_shipped,
)
from isl_core.filters import FilterSpec
from isl_core.filters.imm import imm_kbf
from isl_core.filters.isl import model_aware_isl
from isl_core.scenario.cost import filter_costs
from isl_core.scenario.periods import PeriodRatios
from isl_core.scenario.run import scenario_grid
from isl_core.scenario.table import knob_text
from isl_core.scenario.tuning import FAMILIES, Tuning, tune

from .text import R_MIN, powers

__all__ = [
    "LOOP",
    "PICTURE_MAX_STEPS",
    "Picture",
    "ScenarioRequest",
    "costs",
    "picture_csv",
    "picture_filters",
    "scenario_picture",
    "tuning_for",
]

#: runs × steps of one picture: its ten filters (the IMM's 16 modes the most) then take seconds, not minutes, on a
#: two-core machine (:ref:`performance-scenario`)
PICTURE_MAX_STEPS = 2_000_000
SHORT_PER_WINDOW = 10  #: short windows per rolling window (the rolling window moves by a tenth of its width)
TUNED_ISL = "isl_tuned"  #: the picture's name of paper A's ISL filter at the tuned ν (its own ISL runs at the page's ν)


@dataclass(frozen=True)
class ScenarioRequest:
    """What one picture needs: the model, ν, the σ range of the learning filters, the scenario and its settings."""

    alpha: float
    beta: float
    sigma: float
    m: int
    nu: float
    seed: int
    sigma_range: tuple[float, float]
    scenario: Scenario
    horizon: float
    window: float
    runs: int

    @property
    def model(self) -> Model:
        return Model(self.alpha, self.beta, self.sigma, self.m)


@dataclass(frozen=True)
class Picture:
    """A computed picture: the runs, the rolling ratios, the period statistic (None with one run), each filter's
    tuning in words (by name), where the tuning came from, and the request."""

    request: ScenarioRequest
    average: ScenarioAverage
    rolling: Rolling
    periods: PeriodRatios | None
    tuning: dict[str, str]
    origin: str
    filters: tuple[FilterSpec, ...] = ()  #: the filters beyond the loop's own three (the costs are theirs)
    tuned: Tuning | None = None  #: the tuning the filters took their knobs from (None: untuned or shipped)
    costs: dict[str, float] | None = None  #: ns a step of each filter (:func:`costs`)
    shipped: ShippedTuning | None = None  #: the shipped tuning the filters took their knobs from, if one did


def tuning_for(req: ScenarioRequest) -> Tuning | ShippedTuning | None:
    """The cached tuning of paper A's model with the page's α, m and w = β/√(2α) (A.25), else the shipped one nearest
    it, or None (α = 0, or an m without shipped tunings: :func:`isl_core.scenario.tuning.tune` computes it, minutes
    on two cores)."""
    if req.alpha <= 0.0:
        return None
    w = req.beta / math.sqrt(2.0 * req.alpha)
    cached = tune(req.alpha, m=req.m, w=w, compute=False)
    return cached if cached is not None else shipped_tuning(req.alpha, req.m, w)


def _tuned(req: ScenarioRequest, tuning: Tuning | ShippedTuning) -> tuple[list, dict[str, str]]:
    model, specs, words = req.model, [], {}
    near = isinstance(tuning, ShippedTuning) and not tuning.exact
    how = f"tuned at α = {tuning.alpha:g}, m = {tuning.m} (nearest grid point)" if near else "tuned"
    for family, spec in zip(FAMILIES, tuning.tuned_filters(model), strict=True):
        text = powers(knob_text(tuning.knobs[tuning.minimax(family)]))
        if family == "isl":
            spec = dataclasses.replace(spec, name=TUNED_ISL, label=f"ISL (paper A), tuned {text}")
        specs.append(dataclasses.replace(spec, label=powers(spec.label)))
        words[spec.name] = f"{how}: {text}"
    return specs, words


def _untuned(req: ScenarioRequest) -> tuple[list, dict[str, str]]:
    model, lo_hi = req.model, req.sigma_range
    guess = math.sqrt(lo_hi[0] * lo_hi[1])
    specs = [
        model_aware_isl(model, req.nu),
        adaptive_kbf(model, sigma_range=lo_hi, sigma_init=guess),
        variational_kbf(model, sigma_init=guess),
        robust_kbf(model, sigma_range=lo_hi, sigma_init=guess),
        imm_kbf(model),
    ]
    return specs, {s.name: "untuned: the constructor's default" for s in specs}


def picture_filters(
    req: ScenarioRequest, tuning: Tuning | ShippedTuning | None
) -> tuple[list[FilterSpec], dict[str, str]]:
    """The picture's filters beyond the loop's own three, at the knobs of ``tuning`` (None: the constructors'
    defaults), and each one's tuning in words."""
    return _tuned(req, tuning) if tuning is not None else _untuned(req)


def scenario_picture(req: ScenarioRequest, progress=None) -> Picture:
    """Simulate ``req`` (module docstring); a ``ValueError`` in words if it is too long for the dashboard."""
    tuning = tuning_for(req)
    extra, words = picture_filters(req, tuning)
    grid = tuning.grid_filters(req.model) if tuning is not None else None
    _, n, _ = scenario_grid(req.model, req.nu, req.scenario, [*extra, *(grid or [])], req.horizon)
    if n * req.runs > PICTURE_MAX_STEPS:
        most = max(1, PICTURE_MAX_STEPS // n)
        raise ValueError(
            f"{req.runs} runs of {n:,} steps are {n * req.runs:,} steps, over the dashboard's "
            f"{PICTURE_MAX_STEPS:,} for a scenario: lower the runs averaged (sc_runs) to {most} or the "
            "scenario horizon (sc_horizon)"
        )
    windows = max(1, min(n, round(SHORT_PER_WINDOW * req.horizon / req.window)))
    first = req.seed + (max(tuning.seeds) + 1 if tuning is not None else 0)  # held out: after the tuning's seeds
    avg = average_scenario(
        req.model,
        req.nu,
        req.scenario,
        seeds=range(first, first + req.runs),
        horizon=req.horizon,
        windows=windows,
        extra=extra,
        progress=progress,
        grid_filters=grid,
    )
    periods = avg.periods() if req.runs > 1 else None
    words = {"clairvoyant": "knows σ(t)", "kbf": "knows σ(0)", "isl": "the ν input", **words}
    origin = (
        f"{tuning.origin.replace('r_min', R_MIN)}; this picture's runs are seeds {first}–{first + req.runs - 1}, "
        "held out from the tuning's"
        if tuning is not None
        else f"untuned: {why_not_shipped(req.alpha, req.m)}; the filters that learn σ run at their constructors' "
        "defaults"
    )
    exact = tuning if isinstance(tuning, Tuning) else None
    shipped = tuning if isinstance(tuning, ShippedTuning) else None
    pic = Picture(req, avg, avg.rolling(req.window), periods, words, origin, tuple(extra), exact, shipped=shipped)
    return dataclasses.replace(pic, costs=costs(pic))


#: the filters every scenario loop runs together: their cost is the loop's own
LOOP = ("clairvoyant", "kbf", "isl")
#: measured costs by (m, the filters' labels): a class's server measures once
_COSTS: dict[tuple, dict[str, float]] = {}


def costs(pic: Picture) -> dict[str, float]:
    """ns a step of each filter of the picture beside the loop's own three (:func:`isl_core.scenario.cost.filter_costs`:
    the least of three runs), measured once per server for each set of filters (a step's cost does not depend on σ); the
    loop's three (:data:`LOOP`) run together and cost its base, under the key ``"loop"``."""
    key = (pic.request.m, tuple(s.label for s in pic.filters))
    if key not in _COSTS:
        measured = filter_costs(pic.average.run.model, list(pic.filters), horizon=60.0, copies=4, repeats=3)
        _COSTS[key] = {"loop": measured.base, **measured.ns_per_step}
    return _COSTS[key]


def picture_csv(pic: Picture) -> str:
    """The picture's rolling ratios, intervals, σ(t) and σ̂(t) as CSV, its settings and tunings in ``#`` lines."""
    req, roll, run = pic.request, pic.rolling, pic.average.run
    out = io.StringIO()
    out.write(
        f"# isl scenario picture: alpha={req.alpha:g} beta={req.beta:g} sigma(0)={req.sigma:g} m={req.m} "
        f"nu={req.nu:g} seeds={req.seed}..{req.seed + req.runs - 1} horizon={req.horizon:g}/r_min "
        f"window={roll.width:g}/r_min sigma_range={req.sigma_range[0]:g}..{req.sigma_range[1]:g}\n"
    )
    out.write(f"# scenario: {req.scenario!r}\n# tuning: {pic.origin}\n")
    for name, label in zip(run.names, run.labels, strict=True):
        out.write(f"# {name}: {label} ({pic.tuning.get(name, '')})\n")
    out.write(
        "# ratio: RMSE of the filter over the clairvoyant filter's exact sd, worst coordinate, mean square over "
        "the seeds (simulated; a maximum over noisy coordinates: biased upwards); low/high: 95 % interval\n"
    )
    names = run.names
    cols = ["t_over_r_min", "sigma"] + [f"sigma_hat_{n}" for n in pic.average.learning]
    for n in names:
        cols += [f"ratio_{n}", f"low_{n}", f"high_{n}", f"coordinate_{n}"]
    out.write(",".join(cols) + "\n")
    for j, t in enumerate(roll.t):
        row = [f"{t:.6g}", f"{roll.sigma[j]:.6g}", *(f"{v:.6g}" for v in roll.sigma_hat[j])]
        for f in range(len(names)):
            row += [
                f"{roll.ratio[j, f]:.6g}",
                f"{roll.low[j, f]:.6g}",
                f"{roll.high[j, f]:.6g}",
                str(int(roll.coordinate[j, f]) + 1),
            ]
        out.write(",".join(row) + "\n")
    return out.getvalue()
