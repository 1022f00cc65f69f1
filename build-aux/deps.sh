#!/bin/sh
# Installs the Debian 12 packages a make target needs, only those missing.
# Usage: build-aux/deps.sh GROUP...   (groups: build test bench demo)
# Runs apt-get as root, or through sudo; does nothing when all are present.
set -eu

# Each group names every package it needs itself, Recommends included:
# the install below passes --no-install-recommends, and nothing may work only
# because another group (or a Recommends) happened to bring it in.
#   build: the compiler and libc headers (gcc only Recommends libc6-dev),
#          libsystemd (sd_notify), libmodbus (the RTU serial line), libsodium
#          (HMAC-SHA256 and constant-time compares for authentication).
#   test:  cmocka, clang + its runtime (sanitizers, libFuzzer), scipy (the
#          oracles), the real peers the end-to-end tests drive (mbpoll,
#          pymodbus and serial_asyncio, which pymodbus 3.0 imports at start,
#          socat, haproxy), valgrind, systemd's tools (socket activation,
#          systemd-analyze), man-db (man -l) and gnuplot (stability charts),
#          and a one-node Slurm cluster (tests/e2e/test_slurm.sh): munge,
#          slurmctld, slurmd, slurm-client (sbatch, squeue, scontrol, scancel)
#          and slurm-wlm-basic-plugins (the plugins its slurm.conf names).
#          Their Recommends are left out on purpose: slurm-wlm-plugins is a
#          metapackage of optional plugins (elasticsearch, hdf5, ipmi, ...)
#          and libhwloc-plugins adds hwloc's PCI and GPU discovery; the test
#          runs without either.
#          The Python client (client/python, tests/e2e/test_python_client.sh)
#          needs numpy (python3-numpy: scipy depends on it, named here since
#          the client imports it itself) and installs itself offline with
#          pip and Debian's setuptools and wheel (python3-pip,
#          python3-setuptools, python3-wheel; pip's Recommends,
#          build-essential and python3-dev, are for compiled extensions and
#          the client has none).
pkgs_build="gcc libc6-dev make pkg-config libsystemd-dev libmodbus-dev libsodium-dev"
pkgs_test="libcmocka-dev clang libclang-rt-14-dev python3 python3-scipy python3-numpy \
python3-pip python3-setuptools python3-wheel \
python3-pymodbus python3-serial-asyncio mbpoll socat haproxy valgrind systemd \
man-db groff-base gnuplot-nox procps \
munge slurmctld slurmd slurm-client slurm-wlm-basic-plugins"
pkgs_bench="libgsl-dev libcubature-dev gnuplot-nox redis-server redis-tools"
pkgs_demo="gnuplot-nox"

want=""
for group in "$@"; do
    case "$group" in
    build) want="$want $pkgs_build" ;;
    test) want="$want $pkgs_test" ;;
    bench) want="$want $pkgs_bench" ;;
    demo) want="$want $pkgs_demo" ;;
    *) echo "deps.sh: unknown group '$group'" >&2; exit 2 ;;
    esac
done

missing=""
for p in $want; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
        missing="$missing $p"
    fi
done
[ -z "$missing" ] && exit 0

echo "deps.sh: installing Debian packages:$missing" >&2
if [ "$(id -u)" -eq 0 ]; then sudo=""; else sudo="sudo"; fi
# apt-get update only when the package lists are missing or a day old, so a
# rerun on a provisioned machine does not touch the network.
if [ -z "$(find /var/lib/apt/lists -maxdepth 1 -name '*_Packages*' -mtime -1 2>/dev/null | head -n 1)" ]; then
    $sudo apt-get update -q
fi
# shellcheck disable=SC2086
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends $missing
