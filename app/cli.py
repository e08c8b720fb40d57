"""What the dashboard adds to the core's ``isl`` command (:mod:`isl_core.cli`), where the ``app`` extra is installed.

    isl figure3 [--sigmas 20 200] [--alpha A] [--w W] [--nu NU] [--seed K] [--out DIR]
    isl sweep ... [--no-png]            (the core's sweep, plus fig2.html and fig2.png)
    isl serve [options of app.serving.serve]

Every computation is the core's; this module only draws figures (:mod:`app.static_figures`) and serves the app.
The core's console script loads :func:`extension` through the ``isl.cli`` entry point; :func:`main` is the same
command for a checkout that is not installed.
"""

from __future__ import annotations

import importlib
import sys
from importlib.util import find_spec
from pathlib import Path

from isl_core.cli import Extension, positive, seed_number
from isl_core.cli import main as core_main

__all__ = ["DASHBOARD", "REQUIRES", "extension", "main"]

#: the libraries of the ``app`` extra (pyproject.toml) that the dashboard's commands import
REQUIRES = ("panel", "bokeh", "param", "matplotlib")


def sweep_figures(res, out: Path, args) -> list[Path]:
    """The sweep's fig2.html and, unless ``--no-png``, fig2.png."""
    from .static_figures import fig2_html, fig2_png

    written = [fig2_html(res, out / "fig2.html")]
    if not args.no_png:
        written.append(fig2_png(res, out / "fig2.png"))
    return written


def cmd_figure3(args) -> int:
    """Paper A's Fig. 3 (one trajectory per σ) as fig3.html and fig3.png in --out."""
    from isl_core import Model
    from isl_core.runview import simulate_view

    from .static_figures import fig3_html, fig3_png

    runs = []
    for sigma in args.sigmas:
        model = Model.from_w(args.alpha, args.w, sigma, args.m)
        nu = model.beta if args.nu is None else args.nu
        runs.append(simulate_view(model, nu, horizon=args.horizon, seed=args.seed))  # as the dashboard shows it
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    written = [fig3_html(runs, out / "fig3.html")]
    if not args.no_png:
        written.append(fig3_png(runs, out / "fig3.png"))
    for run in runs:
        print(
            f"sigma = {run.model.sigma:g}: ratio_hat = {_fmt(run.tracks[0].ratio)}, "
            f"ratio_check = {_fmt(run.tracks[1].ratio)}"
        )
    for p in written:
        print(f"wrote {p}")
    return 0


def _fmt(values) -> str:
    return "[" + ", ".join(f"{v:.3f}" for v in values) + "]"


def add_commands(sub, parsers, common) -> None:
    """``figure3`` and ``serve``, and the sweep's figures."""
    parsers["sweep"].add_argument("--no-png", action="store_true", help="skip the PNG")
    parsers["sweep"].set_defaults(figures=sweep_figures)

    p = sub.add_parser("figure3", help="paper A's Fig. 3 as HTML and PNG")
    p.add_argument("--sigmas", type=positive, nargs="+", default=[20.0, 200.0])
    p.add_argument("--alpha", type=positive, default=0.5)
    p.add_argument("--nu", type=positive, default=None, help="ISL tuning ν (default β)")
    p.add_argument("--seed", type=seed_number, default=0)
    p.add_argument("--out", default="isl-fig3", help="output directory (default ./isl-fig3)")
    p.add_argument("--no-png", action="store_true", help="skip the PNG")
    common(p, horizon=10.0)
    p.set_defaults(func=cmd_figure3)

    sub.add_parser("serve", help="serve the dashboard (options: isl serve --help)", add_help=False)


def serve(argv: list[str]) -> int:
    """``isl serve``: :func:`app.serving.serve.main` with the rest of the command line."""
    try:
        module = importlib.import_module("app.serving.serve")
    except ModuleNotFoundError as exc:
        if exc.name not in ("app.serving.serve", "app.serving", "app"):
            raise
        print("isl serve: the dashboard server (app.serving) is not installed in this checkout", file=sys.stderr)
        return 2
    return int(module.main(argv) or 0)


#: what the dashboard adds to the core's ``isl``
DASHBOARD = Extension(add=add_commands, passthrough={"serve": serve})


def extension() -> Extension:
    """:data:`DASHBOARD` — the ``isl.cli`` entry point the core's ``isl`` loads — or ``ModuleNotFoundError`` naming
    what is missing when the ``app`` extra is not installed (checked without importing it: ``isl run`` stays quick)."""
    missing = [name for name in REQUIRES if not _importable(name)]
    if missing:
        raise ModuleNotFoundError(f"the dashboard needs {', '.join(missing)} (the app extra)", name=missing[0])
    return DASHBOARD


def _importable(name: str) -> bool:
    try:
        return find_spec(name) is not None
    except ImportError:
        return False


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``isl`` console script; returns the exit code."""
    return core_main(argv, DASHBOARD)


if __name__ == "__main__":
    sys.exit(main())
