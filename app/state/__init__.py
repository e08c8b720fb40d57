"""A session's state: :class:`AppState` (the model, the run, the page's message) and the rooms it composes, one per
concern — :class:`BaselinesRoom`, :class:`SweepRoom`, :class:`WorstCaseRoom`, :class:`ScenarioRoom`,
:class:`DataRoom` (each a :class:`Room`). Every input is reached by its key (its name in links): :meth:`AppState.get`,
:meth:`AppState.set`, :meth:`AppState.set_inputs`, :meth:`AppState.watch`; :data:`PARAMS` holds each key's
declaration."""

from __future__ import annotations

from .baselines import BaselinesRoom
from .data import DataRoom
from .room import Room
from .scenarios import ScenarioRoom
from .session import (
    ALL_INPUTS,
    DISPLAY_INPUTS,
    INPUTS,
    KINDS,
    OWNERS,
    PARAMS,
    ROOMS,
    TABS,
    VIEWS,
    AppState,
    input_label,
)
from .sweep import SweepRoom
from .worstcase import WorstCaseRoom

__all__ = [
    "ALL_INPUTS",
    "DISPLAY_INPUTS",
    "INPUTS",
    "KINDS",
    "OWNERS",
    "PARAMS",
    "ROOMS",
    "TABS",
    "VIEWS",
    "AppState",
    "BaselinesRoom",
    "DataRoom",
    "Room",
    "ScenarioRoom",
    "SweepRoom",
    "WorstCaseRoom",
    "input_label",
]
