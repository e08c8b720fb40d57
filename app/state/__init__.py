"""A session's state: :class:`AppState` (the model, the run, the page's message) and the rooms it composes, one per
concern — :class:`BaselinesRoom`, :class:`SweepRoom`, :class:`WorstCaseRoom`, :class:`ScenarioRoom`,
:class:`DataRoom` (each a :class:`Room`; those with one long job a :class:`LongJobRoom`). Every input is reached by its
key (its name in links): :meth:`AppState.get`, :meth:`AppState.set`, :meth:`AppState.set_inputs`,
:meth:`AppState.watch`; :func:`declaration` gives its declaration, the input's one check."""

from __future__ import annotations

from .baselines import BaselinesRoom
from .data import DataRoom
from .room import LongJobRoom, Room
from .scenarios import ScenarioRoom
from .session import (
    ALL_INPUTS,
    DISPLAY_INPUTS,
    INPUTS,
    OWNERS,
    ROOMS,
    SIGMA_ENDS,
    TABS,
    VIEWS,
    AppState,
    declaration,
    input_label,
)
from .sweep import SweepRoom
from .worstcase import WorstCaseRoom

__all__ = [
    "ALL_INPUTS",
    "DISPLAY_INPUTS",
    "INPUTS",
    "OWNERS",
    "ROOMS",
    "SIGMA_ENDS",
    "TABS",
    "VIEWS",
    "AppState",
    "BaselinesRoom",
    "DataRoom",
    "LongJobRoom",
    "Room",
    "ScenarioRoom",
    "SweepRoom",
    "WorstCaseRoom",
    "declaration",
    "input_label",
]
