#!/bin/sh
# Correct answers that carry a flag, on the Genz families at ordinary
# (testpack) parameters: usage smooth_flags.sh QMC METHOD [CASES]
q=$1 m=$2 n=${3:-30}
for fam in genz-oscillatory genz-product-peak genz-corner-peak genz-gaussian; do
    /usr/bin/python3 "$(dirname "$0")/peak_scan.py" "$q" "$m" "$n" 7 "$fam" 0 0 | tail -1
done
