# robodyn: rigid-body dynamics over HTTP. Build and run:
#   docker build -t robodyn .
#   docker run -p 8000:8000 -v robodyn-data:/data robodyn
# With a co-located client (a sidecar container of the same user, 10001), the API also on a
# Unix socket in a shared in-memory volume; large batches then go through shared memory there:
#   docker volume create --driver local --opt type=tmpfs --opt device=tmpfs robodyn-run
#   docker run -d -v robodyn-data:/data -v robodyn-run:/run/robodyn \
#     -e ROBODYN_UNIX_SOCKET=/run/robodyn/robodyn.sock robodyn
#   docker run --user 10001 -v robodyn-run:/run/robodyn \
#     -e ROBODYN_URL=unix:///run/robodyn/robodyn.sock your-client-image
# (On machines without a Docker engine: deploy/scripts/container-check.sh builds it with buildah.)
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    PATH=/opt/venv/bin:$PATH

# The OpenMP runtime the `pin` wheels link against: without it `import pinocchio` fails here.
# Not pinned to a version: the base image's Debian release decides it, and a pinned version
# disappears from the archive at the next point release.
# hadolint ignore=DL3008
RUN apt-get update \
 && apt-get install -y --no-install-recommends libgomp1 \
 && apt-get clean \
 && rm -rf /var/lib/apt/lists/*

# The dependencies, pinned (deploy/requirements.lock), in a layer of their own: a change of
# the code alone rebuilds only the small layer below. Wheels only, so no compiler is needed.
# The C++ wheels (cmeel) also ship headers, static libraries and CMake files for building
# against them (about 230 MB); nothing here compiles, so they go.
COPY deploy/requirements.lock /tmp/requirements.lock
RUN python -m venv /opt/venv \
 && pip install --no-cache-dir --only-binary=:all: -r /tmp/requirements.lock \
 && rm /tmp/requirements.lock \
 && prefix="$(python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')/cmeel.prefix" \
 && rm -rf "$prefix/include" "$prefix/lib/cmake" "$prefix/lib/pkgconfig" \
      "$prefix/share/cmake" "$prefix/share/doc" "$prefix/share/man" \
 && find "$prefix" -name '*.a' -delete

# A non-root user (numeric, so Kubernetes' runAsNonRoot can check it) owning the data volume,
# and /run/robodyn, where a volume shared with a co-located client holds the Unix socket.
RUN groupadd --system --gid 10001 robodyn \
 && useradd --system --uid 10001 --gid robodyn --no-create-home --home-dir /nonexistent \
      --shell /usr/sbin/nologin robodyn \
 && mkdir -p /data /run/robodyn \
 && chown 10001:10001 /data /run/robodyn \
 && chmod 0700 /run/robodyn

# The code (the service and the catalog description), importable from /app.
WORKDIR /app
COPY service/ /app/service/
COPY robots/ /app/robots/
ENV PYTHONPATH=/app \
    ROBODYN_DATA_DIR=/data
RUN python -m compileall -q /app

VOLUME ["/data"]
USER 10001:10001
EXPOSE 8000

# `python -c` rather than curl, which the slim image does not have.
HEALTHCHECK --interval=15s --timeout=3s --start-period=30s --retries=3 \
  CMD ["python", "-c", "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/health/live', timeout=2)"]

CMD ["python", "-m", "service", "--host", "0.0.0.0", "--port", "8000"]
