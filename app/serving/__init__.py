"""Serving the dashboard to a class: everything between Panel's server and the page.

* :mod:`app.serving.serve` — the ``isl serve`` / ``python -m app.serving`` command: ``panel serve app/app.py`` with
  safe defaults, a strict warm-up, ``--check`` and ``--health``;
* :mod:`app.serving.webguard` — security headers, the host check, compression and ``/liveness`` on every answer;
* :mod:`app.serving.patches` — every patch of Panel, Bokeh and BokehJS in one table, and the one ``install()`` of the
  Python ones at the server's start-up;
* :mod:`app.serving.hardening` — the exception handler, traceback-free websocket errors, one session's events at a time;
* :mod:`app.serving.session` — what a session's own code uses: its lock, its release hooks, its error notice, its
  page's URL and Panel's files served locally;
* :mod:`app.serving.offloop` — each session's page built on a thread instead of the event loop, and what threads
  hand back to the loop (callbacks, link registrations) made safe to hand over;
* :mod:`app.serving.workers` — one server process per core: how many, forked how, and stopped together;
* :mod:`app.serving.memory` — garbage collection and heap trimming that do not stall a class;
* :mod:`app.serving.fastpath` — less of bokeh's Python when a page's models are serialized (set properties only);
* :mod:`app.serving.static` — the page's static files compressed once per process, on a thread;
* :mod:`app.serving.stalls` — each long stall of the event loop logged with what held it.

The session's own jobs (:mod:`app.jobs.threads`) and the server's long-job queue (:mod:`app.jobs.long`) belong to the
dashboard's pipeline and stay beside it.
"""
