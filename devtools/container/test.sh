#!/usr/bin/env bash
# `make container-test`: build the Dockerfile with podman, run the image and
# check it from outside: the explorer page on a published port, a simulation
# inside, a non-root process, the health check.
#
# No container registry is reachable from the development and CI machines,
# so the base image is made here: a Debian bookworm root (debootstrap from
# apt's configured mirror) with python3 and a venv at /opt/venv, imported as
# localhost/vibtrans-base:bookworm and passed as BASE_IMAGE (the Dockerfile's
# default, python:3.11-slim, is for users).  It is made once per machine and
# reused; so are the build's layers while the sources do not change.
#
# Needs root (podman, runc and debootstrap are installed from Debian's
# packages when missing).  Settings, from the environment:
#   BASE_IMAGE        base image to build on (default: the local one above,
#                     made when missing; any other is pulled by podman)
#   IMAGE             tag of the built image (default localhost/vibtrans:test)
#   DEBIAN_MIRROR     debootstrap's mirror (default: apt's configured one)
#   REBUILD_BASE=1    make the local base image again
#   KEEP=1            leave the test container running (for a look inside)
set -euo pipefail
cd "$(dirname "$0")/../.."

LOCAL_BASE=localhost/vibtrans-base:bookworm
BASE_IMAGE=${BASE_IMAGE:-$LOCAL_BASE}
IMAGE=${IMAGE:-localhost/vibtrans:test}
SUITE=bookworm
T0=$SECONDS

say() { printf '[container-test %4ds] %s\n' "$((SECONDS - T0))" "$*"; }
die() { say "FAILED: $*" >&2; exit 1; }

[ "$(id -u)" -eq 0 ] || die "needs root (podman rootful, debootstrap, apt-get)"

# -- tools -------------------------------------------------------------------
need=()
command -v podman >/dev/null || need+=(podman)
command -v runc >/dev/null || need+=(runc)
command -v iptables >/dev/null || need+=(iptables)      # CNI port publishing
if [ "$BASE_IMAGE" = "$LOCAL_BASE" ]; then
    command -v debootstrap >/dev/null || need+=(debootstrap)
fi
WORK=$(mktemp -d /var/tmp/vibtrans-container-test.XXXXXX)
if [ ${#need[@]} -gt 0 ]; then
    say "installing ${need[*]} (Debian packages)"
    { apt-get -o DPkg::Lock::Timeout=600 update -qq \
      && DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 install -y -qq \
             --no-install-recommends "${need[@]}"; } >"$WORK/apt.log" 2>&1 \
        || { tail -n 30 "$WORK/apt.log" >&2; rm -rf "$WORK"; die "apt-get install ${need[*]}"; }
fi

CTR=vibtrans-test-$$
ROOTFS=
cleanup() {
    status=$?
    if [ "${KEEP:-0}" = 1 ] && [ $status -eq 0 ]; then
        say "KEEP=1: container $CTR left running"
    else
        podman rm -f -t 2 "$CTR" >/dev/null 2>&1 || true
    fi
    [ -n "$ROOTFS" ] && rm -rf --one-file-system "$ROOTFS"
    rm -rf "$WORK"
    exit $status
}
trap cleanup EXIT

# podman's settings for this script only (CONTAINERS_CONF replaces the
# machine's containers.conf): runc; no systemd or journald here; ulimits
# within this machine's hard limits (podman's default, nofile=1048576, makes
# runc fail with "error setting rlimit type 7: operation not permitted"
# where the hard limit is lower: 20000 on the CI and development VMs)
cap() { local v=$1 max=$2; [ "$v" = unlimited ] || [ "$v" -gt "$max" ] && v=$max; echo "$v"; }
nofile=$(cap "$(ulimit -Hn)" 1048576)
nproc=$(cap "$(ulimit -Hu)" 32768)
cat >"$WORK/containers.conf" <<EOF
[containers]
default_ulimits = ["nofile=$nofile:$nofile", "nproc=$nproc:$nproc"]
log_driver = "k8s-file"

[engine]
runtime = "runc"
cgroup_manager = "cgroupfs"
events_logger = "file"
EOF
export CONTAINERS_CONF=$WORK/containers.conf

# -- base image ----------------------------------------------------------------
apt_mirror() {
    # the first Debian (not security) mirror in apt's sources, else deb.debian.org
    local uri
    uri=$(cat /etc/apt/sources.list.d/*.sources 2>/dev/null | sed -n 's/^URIs:[[:space:]]*//p'; \
          cat /etc/apt/sources.list 2>/dev/null | sed -n 's/^deb[[:space:]]\+\(\[[^]]*\][[:space:]]\+\)\?\([^[:space:]]*\).*/\2/p')
    uri=$(printf '%s\n' $uri | grep -E '/debian/?$' | head -n1 || true)
    echo "${uri:-http://deb.debian.org/debian}"
}

make_base() {
    local mirror=${DEBIAN_MIRROR:-$(apt_mirror)}
    ROOTFS=$(mktemp -d /var/tmp/vibtrans-base.XXXXXX)
    say "making $LOCAL_BASE: debootstrap $SUITE from $mirror"
    debootstrap --variant=minbase --include=python3,python3-venv,ca-certificates \
        "$SUITE" "$ROOTFS" "$mirror" >"$WORK/debootstrap.log" 2>&1 \
        || { tail -n 30 "$WORK/debootstrap.log" >&2; die "debootstrap"; }
    # python and pip on PATH, as in python:3.11-slim: a venv at /opt/venv
    chroot "$ROOTFS" /usr/bin/python3 -m venv /opt/venv
    chroot "$ROOTFS" /opt/venv/bin/python -c "import sys, ssl, venv; print(sys.version)"
    chroot "$ROOTFS" apt-get clean
    rm -rf "$ROOTFS"/var/lib/apt/lists/* "$ROOTFS"/usr/share/doc/* \
        "$ROOTFS"/usr/share/man/* "$ROOTFS"/usr/share/info/* "$ROOTFS"/var/log/*.log
    say "importing the root ($(du -sh "$ROOTFS" | cut -f1))"
    tar -C "$ROOTFS" --numeric-owner -c . | podman import --quiet \
        --change 'ENV PATH=/opt/venv/bin:/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
        --change 'ENV LANG=C.UTF-8' \
        --change 'CMD ["python"]' \
        --message "debootstrap $SUITE minbase + python3 venv (devtools/container/test.sh)" \
        - "$LOCAL_BASE" >/dev/null
    rm -rf --one-file-system "$ROOTFS"
    ROOTFS=
}

if [ "$BASE_IMAGE" = "$LOCAL_BASE" ]; then
    if [ "${REBUILD_BASE:-0}" = 1 ] || ! podman image exists "$LOCAL_BASE"; then
        make_base
    else
        say "base image $LOCAL_BASE exists (REBUILD_BASE=1 to make it again)"
    fi
fi

# -- build -------------------------------------------------------------------
# pip inside the build reaches the package index as the host does: the
# host's CA certificates and pip configuration, mounted read-only (mounts
# are not part of the image)
mounts=()
for p in /etc/ssl/certs /etc/pip.conf /etc/xdg/pip; do
    [ -e "$p" ] && mounts+=(-v "$p:$p:ro")
done
proxies=()
for v in http_proxy https_proxy no_proxy HTTP_PROXY HTTPS_PROXY NO_PROXY; do
    [ -n "${!v:-}" ] && proxies+=(--build-arg "$v=${!v}")
done
old_id=$(podman image inspect --format '{{.Id}}' "$IMAGE" 2>/dev/null || true)
say "building $IMAGE on $BASE_IMAGE"
# docker format: OCI images have no HEALTHCHECK
podman build --format docker --build-arg "BASE_IMAGE=$BASE_IMAGE" \
    ${mounts[@]+"${mounts[@]}"} ${proxies[@]+"${proxies[@]}"} \
    -t "$IMAGE" -f Dockerfile . 2>&1 | tee "$WORK/build.log" | grep -E '^(STEP|COMMIT|-->)|rror' || true
[ "${PIPESTATUS[0]}" -eq 0 ] || { tail -n 40 "$WORK/build.log" >&2; die "podman build"; }
new_id=$(podman image inspect --format '{{.Id}}' "$IMAGE")
if [ -n "$old_id" ] && [ "$old_id" != "$new_id" ]; then
    podman rmi "$old_id" >/dev/null 2>&1 || true      # the previous test image
fi
say "built $IMAGE ($(podman image inspect --format '{{.Size}}' "$IMAGE" \
    | awk '{printf "%.0f MB", $1/1e6}'))"

# -- checks --------------------------------------------------------------------
user=$(podman image inspect --format '{{.Config.User}}' "$IMAGE")
case "$user" in ""|root|0|0:*) die "the image runs as root (USER '$user')";; esac
say "ok: image USER $user"

say "simulation inside: vibtrans simulate --json"
podman run --rm --no-healthcheck "$IMAGE" vibtrans simulate --log-amplitude 0 --log-mass 0 \
    --periods 200 --json >"$WORK/simulate.json" \
    || die "vibtrans simulate in the container"
python3 - "$WORK/simulate.json" <<'EOF' || die "the simulation's output"
import json, math, sys
r = json.load(open(sys.argv[1]))
assert math.isfinite(r["drift_velocity"]), r
assert r["scene"]["model"] == "deformable" and r["steps"] > 0, r
print(f"    drift velocity {r['drift_velocity']:.6g}, {r['steps']} steps, "
      f"{r['seconds']:.2f} s, {r['contact']}, {r['pattern']}")
EOF
say "ok: simulation"

port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
say "serving: podman run -p 127.0.0.1:$port:5006"
# (podman reports that it cannot start the health check's systemd timer:
# there is no systemd here; the check is run by hand below)
podman run -d --name "$CTR" -p "127.0.0.1:$port:5006" \
    -e "VIBTRANS_ALLOWED_ORIGINS=localhost:$port,127.0.0.1:$port" "$IMAGE" \
    2> >(grep -v 'systemd connection' >&2) >/dev/null

python3 - "$port" "$CTR" <<'EOF' || { podman logs "$CTR" 2>&1 | tail -n 40 >&2; die "the explorer page"; }
import re, subprocess, sys, time, urllib.request
port, ctr = sys.argv[1], sys.argv[2]
base = f"http://127.0.0.1:{port}"
t0 = time.monotonic()
while True:
    running = subprocess.run(["podman", "inspect", "--format", "{{.State.Running}}", ctr],
                             capture_output=True, text=True).stdout.strip()
    if running != "true":
        sys.exit(f"the container stopped (running: {running!r})")
    try:
        with urllib.request.urlopen(base + "/liveness", timeout=5) as r:
            if r.status == 200:
                break
    except OSError:
        pass
    if time.monotonic() - t0 > 300:
        sys.exit("no answer on /liveness after 300 s")
    time.sleep(1)
print(f"    /liveness answered after {time.monotonic() - t0:.1f} s")
t1 = time.monotonic()
with urllib.request.urlopen(base + "/", timeout=120) as r:
    page = r.read().decode()
    assert r.status == 200, r.status
assert re.search(r"<title>[^<]*vibtrans[^<]*</title>", page), page[:500]
assert "Bokeh" in page, page[:500]
print(f"    explorer page: {len(page)} bytes in {time.monotonic() - t1:.1f} s")
EOF
say "ok: explorer page served on the published port"

uid=$(podman exec "$CTR" id -u)
[ "$uid" != 0 ] || die "podman exec runs as root"
# the server's own process (PID 1 in the container), seen from the host
puser=$(podman top "$CTR" user args | awk 'NR > 1 && /vibtrans/ {print $1; exit}')
[ -n "$puser" ] && [ "$puser" != root ] && [ "$puser" != 0 ] \
    || { podman top "$CTR" user args >&2; die "the server process runs as '${puser:-?}'"; }
say "ok: the server runs as $puser (uid $uid)"

podman healthcheck run "$CTR" || die "podman healthcheck run: unhealthy"
health=$(podman inspect --format '{{.State.Health.Status}}' "$CTR")
[ "$health" = healthy ] || die "health status '$health'"
say "ok: health check ($health)"

podman logs "$CTR" 2>&1 | grep -E 'kernels ready|maps' | sed 's/^/    server: /' || true

t=$SECONDS
podman stop -t 20 "$CTR" 2> >(grep -v 'systemd connection' >&2) >/dev/null
code=$(podman inspect --format '{{.State.ExitCode}}' "$CTR")
[ "$code" = 0 ] || die "podman stop: the server exited with status $code (137: killed)"
say "ok: stopped cleanly by podman stop in $((SECONDS - t)) s (exit status 0)"
say "all container checks passed"
