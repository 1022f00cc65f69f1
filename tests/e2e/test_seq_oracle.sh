#!/bin/sh
# Every sequence kind and scramble against an independent reference
# (tests/vectors/seq_oracle.py, written from docs/SEQUENCES.md in Python
# with exact integers and fractions, never calling our C code): exact
# values at 1500 random (kind, scramble, seed, index, dimension, format)
# cases, from both the per-point and the batch paths.
# Env: QMC (the qmc binary).  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
top="$(cd "$(dirname "$0")/../.." && pwd)"
exec /usr/bin/python3 "$top/tests/vectors/seq_oracle.py" "$QMC" \
    "$top/data/new-joe-kuo-6.21201" "${SEQ_ORACLE_CASES:-1500}"
