# vibtrans explorer.  Build:  docker build -t vibtrans .
# Run:    docker run -p 5006:5006 -e VIBTRANS_ALLOWED_ORIGINS=localhost:5006 vibtrans
# Serve publicly behind a TLS-terminating proxy and set VIBTRANS_ALLOWED_ORIGINS
# to the public host[:port] (comma-separated for several).
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PIP_NO_CACHE_DIR=1 \
    NUMBA_CACHE_DIR=/opt/vibtrans/.numba-cache \
    VIBTRANS_ASSETS=/opt/vibtrans/assets \
    VIBTRANS_ALLOWED_ORIGINS=localhost:5006

WORKDIR /opt/vibtrans
COPY pyproject.toml README.md ./
COPY vibtrans ./vibtrans
COPY app ./app
COPY assets ./assets
RUN pip install . \
    && useradd --system --uid 10001 --home /opt/vibtrans vibtrans \
    && mkdir -p "$NUMBA_CACHE_DIR" \
    # compile every kernel once at build time: the first click pays nothing
    && python -c "import vibtrans; vibtrans.warmup()" \
    && chown -R vibtrans "$NUMBA_CACHE_DIR"

USER vibtrans
EXPOSE 5006
HEALTHCHECK --interval=30s --timeout=5s --start-period=60s \
    CMD python -c "import urllib.request; urllib.request.urlopen('http://127.0.0.1:5006/liveness', timeout=4)"
CMD ["vibtrans", "serve", "--address", "0.0.0.0", "--port", "5006"]
