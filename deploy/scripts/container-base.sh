#!/usr/bin/env bash
# Build, without a Docker engine and without any image registry, a local stand-in for the
# `python:3.11-slim` base image, so that the Dockerfile can be built and its container run on a
# machine that has only Debian's packages (deploy/scripts/container_check.py calls this when no
# python:3.11-slim image is present).
#
#   deploy/scripts/container-base.sh          # once per machine; about 3 minutes; idempotent
#
# What it does: installs buildah and debootstrap from Debian's packages, bootstraps a minimal
# Debian bookworm root file system, adds Python 3.11 with pip and venv (as in the official slim
# image: `python` and `pip` on PATH, pip allowed to install into the system interpreter), and
# tags the result as docker.io/library/python:3.11-slim in buildah's local storage.
#
# Then, from the repository root, build and run the image by hand (or let container_check.py):
#
#   buildah bud --isolation chroot --pull-never --ulimit nofile=20000:20000 \
#       -v /etc/ssl/certs/ca-certificates.crt:/etc/ssl/certs/ca-certificates.crt:ro \
#       -t robodyn:test .
#   ctr=$(buildah from robodyn:test)
#   buildah run --isolation chroot --user app "$ctr" -- python -m service --port 8000 &  # the CMD
#   curl http://127.0.0.1:8000/health/ready
#   buildah rm "$ctr"
#
# Notes:
# - The certificate mount lets pip inside the build reach the package index through the host's
#   network; it is a property of the host, not of the Dockerfile.
# - `buildah run --isolation chroot` shares the host's network, so a server in the container is
#   reached on 127.0.0.1. It does not apply the image's CMD, USER or ENV by itself: read them with
#   `buildah inspect --format '{{.OCIv1.Config.Cmd}} {{.OCIv1.Config.User}}' robodyn:test` and
#   pass them (`--user NAME`, `--env K=V`).
set -euo pipefail

BASE=localhost/debian:bookworm-min
PY=docker.io/library/python:3.11-slim

need() { command -v "$1" >/dev/null 2>&1; }
if ! need buildah || ! need debootstrap; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq buildah debootstrap fuse-overlayfs >/dev/null
fi

if ! buildah inspect --type image "$BASE" >/dev/null 2>&1; then
  root=$(mktemp -d)
  echo "bootstrapping Debian bookworm into $root ..."
  debootstrap --variant=minbase bookworm "$root" >/tmp/container-base-debootstrap.log 2>&1 \
    || { tail -20 /tmp/container-base-debootstrap.log; exit 1; }
  ctr=$(buildah from scratch)
  mnt=$(buildah mount "$ctr")
  cp -a "$root"/. "$mnt"/
  buildah umount "$ctr" >/dev/null
  buildah config --env PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin "$ctr"
  buildah commit -q "$ctr" "$BASE" >/dev/null
  buildah rm "$ctr" >/dev/null
  rm -rf "$root"
fi

if ! buildah inspect --type image "$PY" >/dev/null 2>&1; then
  ctx=$(mktemp -d)
  cat >"$ctx/Dockerfile" <<'EOF'
FROM localhost/debian:bookworm-min
RUN apt-get update \
 && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends \
      python3 python3-pip python3-venv ca-certificates \
 && rm -rf /var/lib/apt/lists/* \
 && rm -f /usr/lib/python3.11/EXTERNALLY-MANAGED \
 && ln -s /usr/bin/python3 /usr/local/bin/python \
 && ln -s /usr/bin/pip3 /usr/local/bin/pip
ENV LANG=C.UTF-8
CMD ["python3"]
EOF
  buildah bud -q --isolation chroot --pull-never --ulimit nofile=20000:20000 -t "$PY" "$ctx" >/dev/null
  rm -rf "$ctx"
fi

echo "ready: $PY (a local stand-in built from Debian packages)"
