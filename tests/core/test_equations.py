"""The papers' equations the code uses can be found by their number, and paper B's explicit filter (B.54) is the
m = 3 case of the core's gains."""
from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from isl_core.nonlinearity import isl_gains

CORE = Path(__file__).resolve().parents[2] / "isl_core"

#: equations the core computes, by their number in paper A (A.n) or paper B (B.n)
USED = ["A.17", "A.21", "A.23", "A.24", "A.29", "A.30", "A.31", "B.4", "B.5", "B.6", "B.7", "B.23", "B.24", "B.25",
        "B.26", "B.46", "B.54"]


def _cited(number: str) -> list[str]:
    """Core modules citing equation ``number`` by itself (``B.4`` is not ``B.40``)."""
    pattern = re.compile(rf"(?<![\w.]){re.escape(number)}(?![\d])")
    return [p.name for p in sorted(CORE.glob("*.py")) if pattern.search(p.read_text("utf-8"))]


@pytest.mark.parametrize("number", USED)
def test_each_equation_the_core_uses_is_cited_by_its_number(number):
    assert _cited(number), f"no module of isl_core cites ({number})"


def test_a_range_does_not_count_as_citing_its_inner_numbers():
    assert not re.search(r"(?<![\w.])B\.5(?![\d])", "B.4–B.7 and B.54")  # the check above is not fooled


@pytest.mark.parametrize("beta", [0.5, 3.0, 20.0])
def test_the_m3_gains_at_nu_equal_beta_are_paper_bs_explicit_filter_b54(beta):
    gamma = lambda p: 2 ** (p / 2) * math.gamma((p + 1) / 2) / math.sqrt(math.pi)  # noqa: E731  E|U|^p
    b54 = [2 * beta ** (1 / 3) * gamma(4 / 3) ** -0.5, 2 * beta ** (2 / 3) * gamma(2 / 3) ** -0.5, beta]
    assert list(isl_gains(3, beta)) == pytest.approx(b54, rel=1e-12)
