"""Keyword arguments of a simulated grid written flat in a test (``horizon=20.0, seeds=(0,), workers=1``), gathered
into the requests the core takes (:class:`isl_core.Sampling`, :class:`isl_core.Execution`, and the worst case's
:class:`isl_core.Candidates`): the requests are made here, so a bad field is refused when the call is made."""

from __future__ import annotations

from isl_core import Candidates, Execution, Sampling

SAMPLING = ("seeds", "horizon", "burn", "batches", "level")
EXECUTION = ("workers", "executor", "chunk", "progress", "cache")
CANDIDATES = {"filters": "names", "sigma_design": "sigma_design", "memory": "memory"}


def requests(candidates: bool = False, **kw) -> dict:
    """``kw`` with its sampling and execution fields (and with ``candidates`` the worst case's filters) made into
    ``sampling=``, ``execution=`` (and ``candidates=``)."""
    out = {k: v for k, v in kw.items() if k not in (*SAMPLING, *EXECUTION, *(CANDIDATES if candidates else ()))}
    out["sampling"] = Sampling(**{k: kw[k] for k in SAMPLING if k in kw})
    out["execution"] = Execution(**{k: kw[k] for k in EXECUTION if k in kw})
    if candidates:
        fields = {name: kw[k] for k, name in CANDIDATES.items() if k in kw}
        if "names" in fields:
            fields["names"] = tuple(fields["names"]) if isinstance(fields["names"], list | tuple) else fields["names"]
        out["candidates"] = Candidates(**fields)
    return out
