"""The kernels' on-disk cache: its directory follows every source file of the package, subpackages included."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import isl_core
from isl_core.kernels.cache import sources_digest


def test_the_kernel_cache_follows_every_source_file_of_the_package(tmp_path):
    """numba keys a cached kernel by its own file, yet compiles into it what it calls from other files (the scenario
    loop inlines kernels/draws.py's draws): after an edit of that file alone it ran the old draws. The cache directory
    is named by a digest of all the package's sources, subpackages included: an edit anywhere in it moves the cache,
    nothing else does."""
    tree = tmp_path / "tree"
    shutil.copytree(Path(isl_core.__file__).parent, tree / "isl_core", ignore=shutil.ignore_patterns("__pycache__"))
    code = "import numba, isl_core.kernels.cache as k; print(k.CACHE, numba.config.CACHE_DIR)"
    env = {**os.environ, "PYTHONPATH": str(tree), "NUMBA_CACHE_DIR": str(tmp_path / "cache")}

    def cache_dir() -> str:
        done = subprocess.run(
            [sys.executable, "-c", code], env=env, cwd=tmp_path, capture_output=True, text=True, check=True
        )
        flag, where = done.stdout.split()
        assert flag == "True" and Path(where).parent == tmp_path / "cache"
        return where

    first = cache_dir()
    assert cache_dir() == first  # the same sources: the same cache
    draws = tree / "isl_core" / "kernels" / "draws.py"
    source = draws.read_text()
    assert "DRAWS = 256" in source
    draws.write_text(source.replace("DRAWS = 256", "DRAWS = 128"))
    assert cache_dir() != first
    assert sources_digest(str(tree / "isl_core")) in cache_dir()
