"""How the kernels are compiled: numba's on-disk cache (:data:`CACHE`) and the floating-point flags (:data:`FASTMATH`).

The kernels are compiled once and cached on disk (numba's ``cache=True``), in a directory ``isl-<digest>`` named by
a digest of every ``*.py`` under ``isl_core/`` (:func:`sources_digest`, subpackages included), under
``NUMBA_CACHE_DIR`` or else under the package's ``isl_core/__pycache__``. numba keys a cached kernel by its own file
only, yet compiles into it the functions it calls from other files: after a change to one of those alone
(``kernels/draws.py`` under the scenario loop, say) it would run the old code; a new digest compiles afresh. (Each
set of sources keeps its directory: a few MB each.) A container may allow no writable place (an arbitrary UID in
group 0, a read-only root file system): numba would then refuse to load the kernels' modules ("cannot cache function
…: no locator available"). :func:`_cache_flag` checks that first; if the place is not writable it points numba at a
directory under the system's temporary directory (``/tmp``, a tmpfs in such containers), and if even that fails it
compiles without a cache (each process then compiles once: :ref:`performance-choices`). Either fallback is said in
one log line (logger
``isl_core``).

``fastmath={"contract"}`` only lets LLVM fuse ``a*b + c`` into one FMA (one rounding instead of two); it
keeps IEEE nan/inf semantics, so a diverging filter still shows up as non-finite. Results are bit-identical
from run to run on one machine.
"""

from __future__ import annotations

import hashlib
import logging
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar, cast

import numba

__all__ = ["CACHE", "FASTMATH", "PACKAGE", "njit", "sources_digest"]

_F = TypeVar("_F", bound=Callable[..., Any])


def njit(**options: Any) -> Callable[[_F], _F]:
    """:func:`numba.njit` with the options given, seen by the type checker as keeping the decorated function's
    signature (numba's decorators are untyped): the kernels are checked, and called, as the functions they compile."""
    return cast("Callable[[_F], _F]", numba.njit(**options))


PACKAGE = Path(__file__).resolve().parents[1]  #: the ``isl_core`` folder, whose sources name the cache
#: FMA contraction only: no reassociation, nan/inf kept (see the module docstring)
FASTMATH = {"contract"}


def _probe() -> None:  # a function of this file, to ask numba whether it can cache this file's functions
    pass


def sources_digest(folder: str | os.PathLike[str] | None = None) -> str:
    """A digest of every ``*.py`` file under ``folder`` (default: the ``isl_core`` package, subpackages included):
    their paths relative to ``folder`` and their contents."""
    root = Path(folder) if folder is not None else PACKAGE
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def _writable(path: str) -> bool:
    try:
        os.makedirs(path, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
        return True
    except OSError:
        return False


def _cache_flag() -> bool:
    """Whether the kernels can be cached on disk, and where (module docstring) — after falling back to a temporary
    directory if need be."""
    here = f"isl-{sources_digest()}"
    place = os.path.join(numba.config.CACHE_DIR or os.path.join(PACKAGE, "__pycache__"), here)
    fallback = os.path.join(
        tempfile.gettempdir(), f"isl-numba-cache-{os.getuid() if hasattr(os, 'getuid') else 0}", here
    )
    for where in (place, fallback):
        if _writable(where):
            numba.config.CACHE_DIR = where
            try:
                njit(cache=True)(_probe)
            except RuntimeError:  # "cannot cache function …: no locator available"
                continue
            if where == fallback:
                logging.getLogger("isl_core").warning(
                    "numba: the cache directory is not writable (%s); caching in %s", place, fallback
                )
            return True
    numba.config.CACHE_DIR = ""
    logging.getLogger("isl_core").warning(
        "numba: no writable cache directory (%s; %s neither): the kernels are compiled in each process", place, fallback
    )
    return False


CACHE = _cache_flag()  #: whether the compiled kernels are cached on disk (see the module docstring)
