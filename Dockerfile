# The isl dashboard as a container: `python -m app.serving` on port 5006, as a non-root user.
#   docker build -t isl .
#   docker run --rm -p 5006:5006 -e ISL_ALLOWED_ORIGINS=localhost:5006 isl
# Settings by environment at `docker run` time: ISL_ALLOWED_ORIGINS (comma-separated host[:port] the browsers
# use to reach the server), ISL_FRAME_ANCESTORS (a course page allowed to frame it), ISL_NUM_PROCS (default: one
# server process per core the container may use; 1: one process), ISL_NUM_THREADS (see app/serving/serve.py).
# docker stop's SIGTERM reaches PID 1, which passes it on to every server process and exits once they have. The image sets PYTHONMALLOC=malloc: a class's memory goes back to the
# OS when it ends (app/serving/memory.py). Its documentation is built into it and served at /docs/. Runs as any
# UID in group 0 (OpenShift) and with --read-only --tmpfs /tmp.
# The base image by digest: python:3.11.14-slim-bookworm (the multi-architecture index).
ARG PYTHON_IMAGE=python:3.11.14-slim-bookworm@sha256:65a93d69fa75478d554f4ad27c85c1e69fa184956261b4301ebaf6dbb0a3543d

FROM ${PYTHON_IMAGE} AS build
ENV PIP_DISABLE_PIP_VERSION_CHECK=1
WORKDIR /src
COPY pyproject.toml README.md requirements.lock ./
COPY isl_core ./isl_core
COPY app ./app
RUN python -m venv /opt/venv \
    && /opt/venv/bin/pip install --no-cache-dir -c requirements.lock ".[app,data]"

# The documentation, which the dashboard serves at /docs/ (a classroom without internet has it): built in a stage of
# its own with the docs extra and MathJax (npm ci of docs/js, copied into the pages by docs/conf.py), warnings as
# errors, so the image carries the pages and not sphinx or npm
FROM build AS docs
RUN apt-get update -qq \
    && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends npm=9.2.0~ds1-1 >/dev/null \
    && rm -rf /var/lib/apt/lists/*
COPY docs ./docs
RUN npm ci --prefix docs/js --no-audit --no-fund \
    && /opt/venv/bin/pip install --no-cache-dir -c requirements.lock ".[docs]" \
    && /opt/venv/bin/python -m sphinx -W --keep-going -q -b html docs /opt/isl-docs

FROM ${PYTHON_IMAGE}
ENV PATH=/opt/venv/bin:$PATH \
    PYTHONUNBUFFERED=1 \
    PYTHONDONTWRITEBYTECODE=1 \
    PYTHONMALLOC=malloc \
    NUMBA_CACHE_DIR=/var/cache/isl/numba \
    ISL_CACHE_DIR=/var/cache/isl/tuning \
    HOME=/tmp \
    ISL_ADDRESS=0.0.0.0 \
    ISL_PORT=5006 \
    ISL_DOCS_DIR=/opt/isl-docs
RUN useradd --create-home --uid 10001 --gid 0 isl \
    && mkdir -p /var/cache/isl/numba \
    && chown -R 10001:0 /var/cache/isl \
    && chmod -R g=u /var/cache/isl
COPY --from=build /opt/venv /opt/venv
COPY --from=docs /opt/isl-docs /opt/isl-docs
USER 10001
WORKDIR /home/isl
# Compile the numba kernel into NUMBA_CACHE_DIR and run the app once: a broken app fails the build. Then the same
# with no writable cache (as under --read-only, or a UID that may not write NUMBA_CACHE_DIR): the kernels must fall
# back to a cache under /tmp instead of refusing to load.
# No tuning at build time: the package ships every family's knob at a grid of α and m
# (isl_core/scenario/data/tunings.json), which the Scenarios tab uses for every model it has not tuned itself
RUN python -m app.serving --check \
    && NUMBA_CACHE_DIR=/proc/isl-read-only python -m app.serving --check \
    && rm -rf /tmp/isl-numba-cache-*
EXPOSE 5006
HEALTHCHECK --interval=30s --timeout=5s --start-period=60s --retries=3 \
    CMD ["python", "-m", "app.serving", "--health"]
CMD ["python", "-m", "app.serving"]
