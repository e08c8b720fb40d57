"""Views of the dashboard: small Viewers that only build widgets and figures over :class:`app.state.AppState`."""

from .about import about_card
from .controls import ControlsView
from .numbers import NumbersView
from .sweep import SweepView
from .trajectories import TrajectoriesView

__all__ = ["ControlsView", "NumbersView", "SweepView", "TrajectoriesView", "about_card"]
