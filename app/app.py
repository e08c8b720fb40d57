"""The isl dashboard (``panel serve app/app.py``, or ``python -m app.serving`` with safe defaults).

The server runs this script for every session, in a fresh namespace: it only builds that session's page. Everything
shared by the sessions lives in the module :mod:`app.page`.
A plain ``panel serve`` runs it without the patches of Panel and Bokeh that ``python -m app.serving`` installs at
its start-up (:mod:`app.serving.patches`): threads, stalls and error replies are then Panel's own.
"""

import sys
from pathlib import Path

if not __package__:  # run as a script (`panel serve app/app.py`): make `app` the package, not this file
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import panel as pn

from app.page import LONG_JOBS, TITLE, LocalFast, SessionGate, create_app, deferred, session_jobs
from app.serving.session import page_location, serve_panel_files, settle_markup_stylesheets

__all__ = ["LONG_JOBS", "TITLE", "LocalFast", "SessionGate", "create_app", "deferred", "session_jobs"]

if pn.state.served:
    serve_panel_files(pn.state.curdoc)  # before anything is built: no stylesheet points at Panel's CDN
    with pn.state.curdoc.models.freeze():  # one walk of the page's models at the end, not one per root added
        create_app().servable(title="isl — Kalman–Bucy vs ISL", location=page_location(pn.state.curdoc))
        settle_markup_stylesheets(pn.state.curdoc)  # their first update then changes no stylesheet
