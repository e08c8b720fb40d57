# The isl dashboard as a container: `python -m app.serve` on port 5006, as a non-root user.
#   docker build -t isl .
#   docker run --rm -p 5006:5006 -e ISL_ALLOWED_ORIGINS=localhost:5006 isl
# Settings by environment at `docker run` time: ISL_ALLOWED_ORIGINS (comma-separated host[:port] the browsers
# use to reach the server), ISL_NUM_PROCS, ISL_NUM_THREADS (see app/serve.py).
ARG PYTHON_IMAGE=python:3.11.14-slim-bookworm

FROM ${PYTHON_IMAGE} AS build
ENV PIP_DISABLE_PIP_VERSION_CHECK=1
WORKDIR /src
COPY pyproject.toml README.md ./
COPY isl_core ./isl_core
COPY app ./app
RUN python -m venv /opt/venv \
    && /opt/venv/bin/pip install --no-cache-dir .

FROM ${PYTHON_IMAGE}
ENV PATH=/opt/venv/bin:$PATH \
    PYTHONUNBUFFERED=1 \
    PYTHONDONTWRITEBYTECODE=1 \
    NUMBA_CACHE_DIR=/var/cache/isl/numba \
    ISL_ADDRESS=0.0.0.0 \
    ISL_PORT=5006
RUN useradd --create-home --uid 10001 --gid 0 isl \
    && mkdir -p /var/cache/isl/numba \
    && chown -R 10001:0 /var/cache/isl \
    && chmod -R g=u /var/cache/isl
COPY --from=build /opt/venv /opt/venv
USER 10001
WORKDIR /home/isl
# Compile the numba kernel into NUMBA_CACHE_DIR and run the app once: a broken app fails the build.
RUN python -m app.serve --check
EXPOSE 5006
HEALTHCHECK --interval=30s --timeout=5s --start-period=60s --retries=3 \
    CMD ["python", "-m", "app.serve", "--health"]
CMD ["python", "-m", "app.serve"]
