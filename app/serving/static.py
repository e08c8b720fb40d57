"""The page's static files (BokehJS, Panel's bundles) compressed once per process, on a thread.

Every page loads about 2 MB of scripts and style sheets from the server's static routes, and the server compresses
text answers (:mod:`!app.serving.webguard`, tornado's ``GZipContentEncoding``). That transform compresses each
answer as it is written, chunk by chunk, on the event loop: for every page a browser opens without those files in
its cache, the loop answers no session and no ``/liveness`` while it compresses them (:ref:`performance-stalls`).

:func:`install` wraps the tornado application's static-file handlers so that a file's compressed form is made once
per process — on :data:`POOL`, not on the loop — kept, and sent as it is (``Content-Encoding: gzip``, so the transform
leaves it alone). A request without ``Accept-Encoding: gzip``, with a ``Range``, for a type that is not compressed
or for a file over :data:`MAX_BYTES` is answered by the handler as before. A file that changes on disk (its size or
modification time) is compressed again.
"""

from __future__ import annotations

import asyncio
import gzip
import mimetypes
import os
from concurrent.futures import Future, ThreadPoolExecutor

import tornado.web

__all__ = ["MAX_BYTES", "POOL", "install", "precompressed"]

MAX_BYTES = 16 * 1024 * 1024  #: larger files are not kept compressed (the page's scripts are far smaller)
MIN_BYTES = tornado.web.GZipContentEncoding.MIN_LENGTH  #: as the transform: smaller answers are sent as they are
LEVEL = tornado.web.GZipContentEncoding.GZIP_LEVEL  #: the transform's compression level
#: compresses the files (zlib releases the interpreter lock while it compresses)
POOL = ThreadPoolExecutor(max_workers=1, thread_name_prefix="isl-static")
_KEPT: dict[str, tuple[tuple[int, int], Future]] = {}  # path → ((size, mtime), its compressed bytes)


def _compress(path: str) -> bytes:
    with open(path, "rb") as f:
        return gzip.compress(f.read(), LEVEL, mtime=0)


def _compressible(path: str) -> bool:
    """As the transform decides (``GZipContentEncoding._compressible_type``), for the type tornado gives the file."""
    ctype = mimetypes.guess_type(path)[0] or "application/octet-stream"
    return ctype.startswith("text/") or ctype in tornado.web.GZipContentEncoding.CONTENT_TYPES


class _Content:
    """``get_content``: the kept compressed bytes on a handler that has them; elsewhere tornado's classmethod (which
    tornado also calls on the class, to hash a file for its ETag)."""

    def __get__(self, handler, cls):
        gz = getattr(handler, "_gz", None)
        if gz is not None:
            return lambda abspath, start=None, end=None: gz[start:end]
        return super(Precompressed, cls).get_content


class Precompressed(tornado.web.StaticFileHandler):
    """A static-file handler that sends a file's kept compressed form when the client accepts it (module docstring).

    Mixed in before the application's own handler class, whose ``get`` must be tornado's."""

    _gz: bytes | None = None

    async def get(self, path: str, include_body: bool = True) -> None:
        self._gz = await self._compressed(path)
        await super().get(path, include_body)

    async def _compressed(self, path: str) -> bytes | None:
        """The file's compressed bytes, made on :data:`POOL` if not kept yet; None where it is sent as before."""
        headers = self.request.headers
        if "gzip" not in headers.get("Accept-Encoding", "") or "Range" in headers:
            return None
        # as tornado's get does (a path it refuses is refused there, again): which file, inside the handler's root
        self.path = self.parse_url_path(path)
        absolute = self.validate_absolute_path(self.root, self.get_absolute_path(self.root, self.path))
        if absolute is None or not _compressible(absolute):
            return None
        try:
            stat = os.stat(absolute)
        except OSError:
            return None
        if not MIN_BYTES <= stat.st_size <= MAX_BYTES:
            return None
        return await asyncio.wrap_future(precompressed(absolute, (stat.st_size, stat.st_mtime_ns)))

    def get_content_size(self) -> int:
        return len(self._gz) if self._gz is not None else super().get_content_size()

    get_content = _Content()  # a classmethod on the class, the kept bytes on a handler that has them

    def set_extra_headers(self, path: str) -> None:
        super().set_extra_headers(path)
        if self._gz is not None:
            self.set_header("Content-Encoding", "gzip")  # the transform then leaves the answer as it is


def precompressed(path: str, version: tuple[int, int]) -> Future:
    """The future compressed bytes of the file ``path`` at ``version`` (its size and modification time), started
    on :data:`POOL` at the first request and kept for the next ones."""
    kept = _KEPT.get(path)
    if kept is None or kept[0] != version or (kept[1].done() and kept[1].exception() is not None):
        kept = _KEPT[path] = (version, POOL.submit(_compress, path))
    return kept[1]


def install(application: tornado.web.Application) -> None:
    """Make every static-file route of ``application`` whose handler uses tornado's ``get`` send kept compressed
    files (idempotent)."""
    for rule in application.wildcard_router.rules:
        target = rule.target
        if (
            isinstance(target, type)
            and issubclass(target, tornado.web.StaticFileHandler)
            and not issubclass(target, Precompressed)
            and target.get is tornado.web.StaticFileHandler.get
        ):
            rule.target = type(f"Precompressed{target.__name__}", (Precompressed, target), {})
