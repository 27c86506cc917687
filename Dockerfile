# vibtrans explorer.  Build:  docker build -t vibtrans .
# Run:    docker run -p 5006:5006 vibtrans      (then http://localhost:5006)
# Serve publicly behind a TLS-terminating proxy and set VIBTRANS_ALLOWED_ORIGINS
# to the public host[:port] (comma-separated for several).
# BASE_IMAGE: any Debian-like image with python >= 3.11 and pip on PATH, and
# useradd; `make container-test` builds on one made locally with debootstrap
# (devtools/container/test.sh).
ARG BASE_IMAGE=python:3.11-slim
FROM ${BASE_IMAGE}

ENV PYTHONDONTWRITEBYTECODE=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    NUMBA_CACHE_DIR=/opt/vibtrans/.numba-cache \
    VIBTRANS_ALLOWED_ORIGINS=localhost:5006

# The dependencies first, in their own layer: a rebuild after a change of
# the sources alone reuses it.
COPY pyproject.toml /tmp/vibtrans-src/
RUN python -c "import tomllib; print(*tomllib.load(open('/tmp/vibtrans-src/pyproject.toml', 'rb'))['project']['dependencies'], sep='\n')" \
        > /tmp/requirements.txt \
    && pip install -r /tmp/requirements.txt \
    && rm /tmp/requirements.txt

# The package holds everything the explorer needs (maps included): install
# it from a scratch copy of the sources, then drop them (.dockerignore keeps
# the build context to what the package is made of).
COPY . /tmp/vibtrans-src
WORKDIR /opt/vibtrans
RUN pip install /tmp/vibtrans-src \
    && rm -rf /tmp/vibtrans-src \
    && useradd --system --uid 10001 --home-dir /opt/vibtrans --shell /usr/sbin/nologin vibtrans \
    && mkdir -p "$NUMBA_CACHE_DIR" \
    # compile every kernel once at build time, into the cache of the
    # installed modules (run from here, not from the sources): the first
    # start and the first click pay nothing
    && python -c "import vibtrans; vibtrans.warmup()" \
    && chown -R vibtrans /opt/vibtrans

USER vibtrans
EXPOSE 5006
# the server is PID 1, which ignores SIGTERM; SIGINT stops it cleanly
STOPSIGNAL SIGINT
HEALTHCHECK --interval=30s --timeout=5s --start-period=60s \
    CMD python -c "import urllib.request; urllib.request.urlopen('http://127.0.0.1:5006/liveness', timeout=4)"
CMD ["vibtrans", "serve", "--address", "0.0.0.0", "--port", "5006"]
