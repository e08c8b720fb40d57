"""The kernels' arguments, bundled by meaning: typed tuples that numba passes as one value each.

A kernel call names what it hands over — the truth's Euler grid, the filter bank, where the squared errors are
summed, where a trajectory is written — instead of counting 23 (:func:`isl_core.kernels.euler.advance`) or 31
(:func:`isl_core.kernels.scenario.advance_scenario`) positions. Each bundle is a :class:`typing.NamedTuple`: numba
compiles it into a struct whose fields the kernel reads once into locals (no cost per step), and caches the kernels
for it like any other argument type. Arrays in a bundle are written in place by the kernels where the field's doc
says so (the state carried from call to call, the sums); the tuples themselves never change.

=================== ==========================================================================================
bundle              what it holds
=================== ==========================================================================================
:class:`Grid`       the truth's Euler grid: h, α, β (B.33)
:class:`FilterBank` the filters packed for a loop: damping, gains, kind codes, gain tables, σ-learners' state
:class:`Batches`    where the constant-σ loop sums squared errors (per batch, after a burn-in)
:class:`Trajectory` where the constant-σ loop writes a stored run (truth, errors, σ̂)
:class:`NoiseLaw`   the law of ε_k (Gaussian, Student-t, outliers) and E ε²
:class:`Observation` what a scenario's filters observe in a chunk: σ_k, the law, a reading every q steps
:class:`FilterState` what the scenario loop carries per filter beyond the bank (readings, deaths, VB state)
:class:`Windows`    where the scenario loop sums per time window
:class:`ClairvoyantState` the clairvoyant recursion's covariance, gain, settled flags and sensor cycle
:class:`IMMState`   the IMM banks' modes, weights and scratch space
:class:`Buckets`    a display run's min/max buckets (:class:`isl_core.decimate.MinMax`)
:class:`Tube`       a display run's counts inside the ±3 s tube and σ̂ sums
=================== ==========================================================================================
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = [
    "Batches",
    "Buckets",
    "ClairvoyantState",
    "FilterBank",
    "FilterState",
    "Grid",
    "IMMState",
    "NoiseLaw",
    "Observation",
    "Trajectory",
    "Tube",
    "Windows",
]


class Grid(NamedTuple):
    """The truth's Euler grid (B.33): step ``h``, the OU rate ``alpha`` = α and ``beta`` = β of X_m."""

    h: float
    alpha: float
    beta: float


class FilterBank(NamedTuple):
    """The filters packed for a loop (:func:`isl_core._engine.pack`), per filter f: its damping a_f ``damp`` (nf,),
    gain or power-law coefficients ``coef`` (nf, m), kind code ``kind`` (nf,) int8 (``KIND_*`` of
    :mod:`isl_core.filters.base`), an adaptive filter's table of log K ``table`` (nf, nt, m), and ``ad`` (nf,
    AD_WIDTH, columns ``AD_*`` of :mod:`isl_core.kernels.common`): the σ-learners' table origin and memory, then the
    state they carry from call to call (written in place)."""

    damp: np.ndarray
    coef: np.ndarray
    kind: np.ndarray
    table: np.ndarray
    ad: np.ndarray


class Batches(NamedTuple):
    """Where the constant-σ loop sums: after ``burn`` steps, batches of ``length`` steps (the last takes the rest);
    squared errors into ``sq`` (nb, nf, m) and the adaptive filters' σ̂ into ``sig_sum`` (nb, na), in place."""

    burn: int
    length: int
    sq: np.ndarray
    sig_sum: np.ndarray


class Trajectory(NamedTuple):
    """Where the constant-σ loop writes a stored run when ``store``: the truth ``X`` (rows, m), the errors ``E`` (nf,
    rows, m) and the adaptive filters' σ̂ ``S`` (na, rows), row r holding step ``first`` + r."""

    store: bool
    first: int
    X: np.ndarray
    E: np.ndarray
    S: np.ndarray

    @classmethod
    def none(cls, nf: int, na: int, m: int) -> Trajectory:
        """No trajectory kept (a long run that sums squared errors only): one-row dummies, never written."""
        return cls(False, 0, np.empty((1, m)), np.empty((nf, 1, m)), np.empty((na, 1)))


class NoiseLaw(NamedTuple):
    """The law of ε_k (:mod:`isl_core.noise`): ``code`` (``LAW_*``), Student's ``dof`` and its ziggurat ``table``,
    the outliers' ``rate`` p and ``scale`` k, and ``variance`` = E ε²."""

    code: int
    dof: float
    table: np.ndarray
    rate: float
    scale: float
    variance: float


class Observation(NamedTuple):
    """What a scenario's filters observe over one chunk of steps: σ_k ``sigma`` (n,) — or (1,), its one value while σ
    is constant —, the noise ``law`` and a sensor reading every ``q`` steps; on a grid refined ``level`` times
    (2^level steps per base step), the Brownian bridge's normals ``bridge`` (base steps, 2^level − 1, 2) that split
    each base step's draws (v, ε) into its fine steps' (:func:`isl_core.kernels.draws.split_ahead`)."""

    sigma: np.ndarray
    law: NoiseLaw
    q: int
    bridge: np.ndarray = np.zeros((0, 1, 2))
    level: int = 0


class FilterState(NamedTuple):
    """What the scenario loop carries per filter beyond the bank, in place: ``acc`` (nf,) the innovation summed since
    the last reading, ``died`` (nf,) int64 the step a filter left the finite numbers (−1 while it lives), and the
    variational-Bayes filters' covariance ``vb_P`` (nf, m, m), inverse-gamma (a, b) ``vb_ab`` (nf, 2) and (ρ,
    iterations) ``vb_par`` (nf, 2) — (c, κ(c)) for a robust filter."""

    acc: np.ndarray
    died: np.ndarray
    vb_P: np.ndarray
    vb_ab: np.ndarray
    vb_par: np.ndarray


class Windows(NamedTuple):
    """Where the scenario loop sums per time window, in place: window w holds the steps k in [``edges[w]``,
    ``edges[w + 1]``); squared errors at t_{k+1} into ``sq`` (nw, nf, m), σ̂ into ``sigma_hat`` (nw, na), and the
    clairvoyant filter's diag P at t_{k+1} and σ_k into ``ref`` (nw, m + 1)."""

    edges: np.ndarray
    sq: np.ndarray
    sigma_hat: np.ndarray
    ref: np.ndarray


class ClairvoyantState(NamedTuple):
    """The clairvoyant recursion's state (:func:`isl_core.kernels.clairvoyant.clairvoyant_step`), in place: ``P``
    (m+1, m+1) the covariance of (X, S); ``flags`` = (R, settled, the previous step's noise, the largest change in
    the current sensor cycle, whether the noise changed in it); ``gain`` (m,) of the latest reading; ``var`` (m,)
    diag P; ``cycle_P`` (q, m+1, m+1) and ``cycle_R`` (q,) P and R after each step of the last sensor cycle (empty
    for q = 1)."""

    P: np.ndarray
    flags: np.ndarray
    gain: np.ndarray
    var: np.ndarray
    cycle_P: np.ndarray
    cycle_R: np.ndarray


class IMMState(NamedTuple):
    """The IMM banks of a scenario run (:func:`isl_core.kernels.imm.imm_state`), one bank b per IMM filter, padded to
    the largest J: ``slot`` (nf,) each filter's bank (−1: none); per bank ``P`` (b, J, m+1, m+1), ``e`` (b, J, m),
    ``a`` (b, J) the innovations since the last reading, ``mu`` (b, J) the weights, ``R`` (b, J) = q·h·σ_j²,
    ``par`` (b, 2) = (switch p, J), ``sigma`` (b, J) = σ_j; scratch ``W`` (J, J), ``V`` and ``out`` (J, nv),
    ``lw`` (J,), ``mean`` (m,)."""

    slot: np.ndarray
    P: np.ndarray
    e: np.ndarray
    a: np.ndarray
    mu: np.ndarray
    R: np.ndarray
    par: np.ndarray
    sigma: np.ndarray
    W: np.ndarray
    V: np.ndarray
    out: np.ndarray
    lw: np.ndarray
    mean: np.ndarray


class Buckets(NamedTuple):
    """A display run's min/max buckets (:class:`isl_core.decimate.MinMax`), per bucket and trace, in place: ``size``
    samples a bucket, the smallest value ``lo_v`` and its sample ``lo_i``, the largest ``hi_v`` and ``hi_i``, and
    ``ends`` (2, traces) the first and the last sample."""

    size: int
    lo_v: np.ndarray
    lo_i: np.ndarray
    hi_v: np.ndarray
    hi_i: np.ndarray
    ends: np.ndarray


class Tube(NamedTuple):
    """A display run's counts, in place: ``inside`` (nf, m) the steps with ``|e_f,i| ≤ bound_i`` (``bound`` (m,)),
    and ``sig_sum`` (na,) the σ̂ sums."""

    bound: np.ndarray
    inside: np.ndarray
    sig_sum: np.ndarray
