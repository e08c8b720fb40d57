"""The ``isl`` command line: one run, the ν-sweep of paper A's Fig. 2, ν recommendations, worst cases.

    isl run [--alpha A] [--beta B | --w W] [--sigma S] [--m M] [--nu NU] [--seed K] [--horizon H] [--json]
    isl sweep [--alphas ...] [--beta B] [--sigmas ...] [--ell-min L --ell-max L] [--horizon H] [--seeds ...] [--out DIR]
    isl recommend [--alphas ...] [--sigmas ...] [--horizon H] [--seeds ...] [--no-verify] [--json]
    isl worstcase [--alphas 0.04,0.2,1,5,25] [--sigma-min 2 --sigma-max 200] [--horizon H] [--seeds ...] [--json]
    isl scenario [--alpha A] [--scenarios sigma_drop,...] [--n-seeds N] [--tune | --map KIND] [--json] [--csv FILE]
    isl data SOURCE [--m M] [--alpha A] [--time COL --value COL] [--holdout F] [--json]

These are the core's (:func:`main`). The ``isl`` console script and ``python -m isl_core`` (:func:`console`) add the
dashboard's :class:`Extension` (:mod:`app.cli`: ``isl figure3``, ``isl serve`` and the sweep's HTML and PNG figures)
where the ``app`` extra is installed; without it those two commands say what to install.
Bad arguments end with exit code 2 and one line on stderr; a diverged filter with exit code 1.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, NoReturn, TypeVar, cast

from isl_core import __version__
from isl_core.cli.commands import UsageError, cmd_recommend, cmd_run, cmd_sweep, cmd_worstcase
from isl_core.cli.data import add_data
from isl_core.cli.scenario import cmd_scenario

_V = TypeVar("_V")

__all__ = [
    "APP_COMMANDS",
    "Extension",
    "UsageError",
    "build_parser",
    "console",
    "installed_extension",
    "main",
    "positive",
    "seed_number",
]

#: the entry-point group through which an installed package adds to ``isl`` (the dashboard: ``app.cli:extension``)
EXTENSIONS = "isl.cli"
#: the commands of the dashboard's ``app`` extra; without it they say what to install
APP_COMMANDS = ("serve", "figure3")
APP_HINT = "the dashboard needs the app extra: pip install 'isl[app]'"


@dataclass(frozen=True)
class Extension:
    """What a package built on the core adds to ``isl``.

    ``add(sub, parsers, common)`` adds sub-commands to ``sub`` (argparse's sub-parsers) or options to the core's
    (``parsers["sweep"]``, ...; a ``figures(res, out, args) -> paths`` default on the sweep's parser writes more
    files); ``common(parser, horizon=...)`` adds the shared ``--m``, ``--w``, ``--horizon``. ``passthrough`` maps a
    command name to a function that parses the rest of the command line itself and returns the exit code.
    """

    add: Callable[..., None] | None = None
    passthrough: Mapping[str, Callable[[list[str]], int]] = field(default_factory=lambda: MappingProxyType({}))


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # argparse would print the usage and exit; we want one line and a code
        raise UsageError(f"{self.prog}: error: {message}")


if TYPE_CHECKING:  # generic to the type checker only
    _Sub = argparse._SubParsersAction[_Parser]  # what add_subparsers returns


def _number(text: str, *, zero: bool) -> float:
    """``text`` as a finite number > 0 (``zero``: >= 0) in ASCII notation (:func:`isl_core.validate.read_real`),
    or argparse's error naming the range."""
    from isl_core.validate import read_real

    want = f"a finite number {'>=' if zero else '>'} 0"
    try:
        x = read_real(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected {want}; {exc}") from None
    if not (x >= 0 if zero else x > 0):
        raise argparse.ArgumentTypeError(f"expected {want}, got {text!r}")
    return x


def positive(text: str) -> float:
    return _number(text, zero=False)


def _nonneg(text: str) -> float:
    return _number(text, zero=True)


def _whole(text: str) -> int:
    """``text`` as a whole number in ASCII digits (:func:`isl_core.validate.read_int`), or argparse's error."""
    from isl_core.validate import read_int

    try:
        return read_int(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected a whole number; {exc}") from None


def seed_number(text: str) -> int:
    k = _whole(text)
    if k < 0:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {text!r}")
    return k


def _comma(kind: Callable[[str], _V]) -> Callable[[str], list[_V]]:
    """argparse type: a comma-separated list of ``kind`` (``"0.04,0.2,1"``)."""

    def parse(text: str) -> list[_V]:
        return [kind(part) for part in text.split(",") if part.strip()] or [kind(text)]

    return parse


def _execution(p: argparse.ArgumentParser) -> None:
    """The sweep's and the worst case's batches and where their runs go."""
    p.add_argument("--batches", type=_whole, default=10, help="batches per seed for the intervals (default 10)")
    p.add_argument("--workers", type=_whole, default=None, help="local threads (default: CPU count)")
    p.add_argument("--dask", metavar="ADDRESS", default=None, help="run on a dask.distributed scheduler")


def _common(p: argparse.ArgumentParser, *, horizon: float) -> None:
    """The options every command shares: ``--m``, ``--w`` and ``--horizon`` (default ``horizon``)."""
    p.add_argument("--m", type=_whole, default=3, help="state dimension 1..6 (default 3)")
    p.add_argument("--w", type=positive, default=3.0, help="stationary std of X_m: β = w√(2α) (default 3)")
    p.add_argument("--horizon", type=positive, default=horizon, help=f"in units of 1/r_min (default {horizon:g})")


def _add_run(sub: _Sub) -> argparse.ArgumentParser:
    """``isl run``: one trajectory."""
    p = sub.add_parser("run", help="one trajectory: s, measured RMSEs and ratios, r_min, h, T")
    p.add_argument("--alpha", type=_nonneg, default=0.5, help="OU rate α >= 0 (default 0.5)")
    p.add_argument("--beta", type=positive, default=None, help="β (default w√(2α); required when α = 0)")
    p.add_argument("--sigma", type=positive, default=20.0, help="observation noise σ (default 20)")
    p.add_argument("--nu", type=positive, default=None, help="ISL tuning ν (default β)")
    p.add_argument("--seed", type=seed_number, default=0)
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    _common(p, horizon=10.0)
    p.set_defaults(func=cmd_run)
    return p


def _add_sweep(sub: _Sub) -> argparse.ArgumentParser:
    """``isl sweep``: paper A's Fig. 2 grid."""
    from isl_core.paper import FIG2_ALPHAS, FIG2_SIGMAS

    p = sub.add_parser(
        "sweep", help="paper A's Fig. 2 grid (or any model's): CSV and JSON (the dashboard's isl adds HTML and PNG)"
    )
    p.add_argument(
        "--alphas", type=_nonneg, nargs="+", default=list(FIG2_ALPHAS), help="OU rates α (α = 0 needs --beta)"
    )
    p.add_argument(
        "--beta",
        type=positive,
        default=None,
        help="one β for every α: any model, α = 0 included (default: paper A's β = w√(2α))",
    )
    p.add_argument("--sigmas", type=positive, nargs="+", default=list(FIG2_SIGMAS))
    p.add_argument("--ell-min", type=_whole, default=-8, help="smallest ℓ of ν/β = 2^ℓ (default −8)")
    p.add_argument("--ell-max", type=_whole, default=2, help="largest ℓ (default 2)")
    p.add_argument("--seeds", type=seed_number, nargs="+", default=[0, 1])
    _execution(p)
    p.add_argument("--out", default="isl-fig2", help="output directory (default ./isl-fig2)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _common(p, horizon=1000.0)
    p.set_defaults(func=cmd_sweep)
    return p


def _add_recommend(sub: _Sub) -> argparse.ArgumentParser:
    """``isl recommend``: ν per α."""
    from isl_core.paper import FIG2_ALPHAS, FIG2_SIGMAS

    p = sub.add_parser("recommend", help="recommended ν per α beside paper A's table (A.31)")
    p.add_argument("--alphas", type=positive, nargs="+", default=list(FIG2_ALPHAS))
    p.add_argument("--sigmas", type=positive, nargs="+", default=list(FIG2_SIGMAS))
    p.add_argument("--seeds", type=seed_number, nargs="+", default=[0, 1])
    p.add_argument("--batches", type=_whole, default=10)
    p.add_argument("--no-verify", action="store_true", help="theory only, no simulation")
    p.add_argument("--json", action="store_true")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _common(p, horizon=1000.0)
    p.set_defaults(func=cmd_recommend)
    return p


def _add_worstcase(sub: _Sub) -> argparse.ArgumentParser:
    """``isl worstcase``: each filter's worst case over a σ range."""
    from isl_core import WORST_CASE_FILTERS
    from isl_core.paper import FIG2_ALPHAS

    p = sub.add_parser("worstcase", help="each filter's worst-case ratio over a sigma range, per alpha")
    p.add_argument(
        "--alphas",
        type=_comma(positive),
        nargs="+",
        default=[list(FIG2_ALPHAS)],
        help="alpha values, comma- or space-separated (default 0.04,0.2,1,5,25)",
    )
    p.add_argument("--sigma-min", type=positive, default=2.0, help="smallest sigma (default 2)")
    p.add_argument("--sigma-max", type=positive, default=200.0, help="largest sigma (default 200)")
    p.add_argument("--n-sigma", type=_whole, default=5, help="log-spaced sigma values in the range (default 5)")
    p.add_argument(
        "--filters",
        type=_comma(str),
        nargs="+",
        default=[list(WORST_CASE_FILTERS)],
        help=f"filters to compare (default {','.join(WORST_CASE_FILTERS)})",
    )
    p.add_argument(
        "--sigma-design",
        type=positive,
        default=None,
        help="sigma of the mismatched KBF (default the geometric middle of the range)",
    )
    p.add_argument(
        "--memory",
        type=positive,
        default=1000.0,
        help="adaptive KBF memory W in readings (= steps in these runs; default 1000)",
    )
    p.add_argument("--seeds", type=_comma(seed_number), nargs="+", default=[[0, 1]])
    _execution(p)
    p.add_argument("--json", action="store_true", help="print JSON instead of the table")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _common(p, horizon=1000.0)
    p.set_defaults(func=cmd_worstcase)
    return p


def _add_scenario(sub: _Sub) -> argparse.ArgumentParser:
    """``isl scenario``: the fair table, the tuning curves, the who-wins maps."""
    from isl_core.scenario.table import PRESETS

    p = sub.add_parser(
        "scenario",
        help="beyond constant sigma: the fair table of every filter's period ratio to the "
        "clairvoyant Kalman filter, each family tuned by one rule; --tune: the tuning curves",
    )
    p.add_argument("--alpha", type=positive, default=1.0, help="alpha of paper A's model (default 1)")
    p.add_argument(
        "--scenarios",
        type=_comma(str),
        nargs="+",
        default=[list(PRESETS)],
        help=f"scenarios (default {','.join(PRESETS)}): also the set the knobs are tuned over",
    )
    p.add_argument(
        "--tune",
        action="store_true",
        help="instead of the table: the tuning curves (each variant's ratio per scenario and period)",
    )
    p.add_argument(
        "--map",
        choices=["sigma_step", "tails", "sensor"],
        default=None,
        help="instead of the table: who wins over sigma-step ratio x time since the step, over the noise's "
        "degrees of freedom, or over the sensor interval (the table's tuning)",
    )
    p.add_argument(
        "--values",
        type=_comma(_nonneg),
        nargs="+",
        default=None,
        help="the map's values (default: sigma ratios 0.1..10, d = 2.5..100, intervals 0..0.5/r_min)",
    )
    p.add_argument("--untuned", action="store_true", help="the map's filters at the constructors' defaults")
    p.add_argument(
        "--n-seeds", type=_whole, default=None, help="how many tuning seeds (default 32: 0..31); a map's: per cell"
    )
    p.add_argument(
        "--n-report-seeds",
        type=_whole,
        default=None,
        help="how many held-out seeds the table is read on, after the tuning's (default 4 x --n-seeds)",
    )
    p.add_argument(
        "--window", type=positive, default=1.0, help="the sigma_step map's rows, units of 1/r_min (default 1)"
    )
    p.add_argument(
        "--burn",
        type=_nonneg,
        default=2.0,
        help="start left out where sigma does not change, units of 1/r_min (default 2)",
    )
    p.add_argument(
        "--rate",
        type=positive,
        default=100.0,
        help="sensor readings per 1/r_min at sigma(0), the same for every filter (default 100)",
    )
    p.add_argument("--refine", type=_whole, default=0, help="halvings of the Euler step below a reading (default 0)")
    p.add_argument("--level", type=positive, default=0.95, help="confidence level of the intervals (default 0.95)")
    p.add_argument("--workers", type=_whole, default=None, help="threads of the tuning runs (default: CPU count)")
    p.add_argument(
        "--no-cache", action="store_true", help="compute the tuning even if it is cached, keep it in memory only"
    )
    p.add_argument("--no-cost", action="store_true", help="do not measure each filter's ns per step")
    p.add_argument("--json", action="store_true", help="print JSON instead of the table")
    p.add_argument("--csv", type=Path, default=None, help="also write the table (or the curves) as CSV to this file")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _common(p, horizon=30.0)
    p.set_defaults(func=cmd_scenario)
    return p


def build_parser(extension: Extension | None = None) -> argparse.ArgumentParser:
    """The ``isl`` parser: the core's commands and what ``extension`` adds."""
    top = _Parser(
        prog="isl",
        description="Kalman–Bucy vs the ISL filter: simulations, paper A's Fig. 2 sweep, recommended nu, worst cases.",
    )
    top.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = top.add_subparsers(dest="command", required=True, parser_class=_Parser)
    parsers = {
        name: add(sub)
        for name, add in (
            ("run", _add_run),
            ("sweep", _add_sweep),
            ("recommend", _add_recommend),
            ("worstcase", _add_worstcase),
            ("scenario", _add_scenario),
            ("data", lambda sub: add_data(sub, positive, _nonneg, _whole)),
        )
    }
    if extension is not None and extension.add is not None:
        extension.add(sub, parsers, _common)
    return top


def _fail(message: str, code: int) -> int:
    print(" ".join(message.split()), file=sys.stderr)  # exactly one line
    return code


def installed_extension() -> Extension | None:
    """The :class:`Extension` an installed package declares in the ``isl.cli`` entry-point group, if it loads: the
    dashboard's needs its ``app`` extra (Panel, Bokeh, param, matplotlib), and without it there is none."""
    from importlib.metadata import entry_points

    for point in entry_points(group=EXTENSIONS):
        try:
            return cast("Extension", point.load()())
        except ImportError:
            continue
    return None


def _needs_app(command: str) -> Callable[[list[str]], int]:
    def refuse(argv: list[str]) -> int:
        return _fail(f"isl {command}: {APP_HINT}", 2)

    return refuse


def console(argv: list[str] | None = None) -> int:
    """The ``isl`` console script: the core's commands, and the dashboard's where its ``app`` extra is installed
    (without it, ``isl serve`` and ``isl figure3`` say what to install and exit with code 2)."""
    extension = installed_extension()
    if extension is None:
        extension = Extension(passthrough=MappingProxyType({name: _needs_app(name) for name in APP_COMMANDS}))
    return main(argv, extension)


def main(argv: list[str] | None = None, extension: Extension | None = None) -> int:
    """Run ``isl`` with ``argv`` (default: the process's arguments) and ``extension``'s commands; the exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    passthrough = extension.passthrough if extension is not None else {}
    if argv and argv[0] in passthrough:
        return int(passthrough[argv[0]](argv[1:]) or 0)
    try:
        args = build_parser(extension).parse_args(argv)
        return cast("int", args.func(args))
    except SystemExit as exc:  # --help / --version
        return exc.code if isinstance(exc.code, int) else 0
    except UsageError as exc:
        return _fail(str(exc), 2)
    except ValueError as exc:  # the core's boundary checks name the parameter and its range
        return _fail(f"isl: error: {exc}", 2)
    except ArithmeticError as exc:  # isl_core.DivergenceError
        return _fail(f"isl: {exc}", 1)
    except KeyboardInterrupt:
        print("isl: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
