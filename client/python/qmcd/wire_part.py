"""qmcd.wire_part - what the wire knows of a part session's answer
(PROTOCOL.md section 6.22), beside wire.py's tables: the 608-byte record
of one block's sums as a numpy dtype, the blocks part k of p takes, and
the checks the C decoder makes of SESSION_PART and SESSION_PART_SUMS
(protocol/messages_part.c): the part's range is part k of p of its job's
blocks, a record's counts fit a block, its largest values are
non-negative and descending.  The sums themselves are any binary64,
carried bit for bit.

Must not: touch a socket, a file or the clock, or keep state; import
wire.py (which imports this).
"""
import math

import numpy as np

SAMPLING_BLOCK = 4096                  # points a block of a sampling job
SAMPLING_MAX_BLOCKS = 1 << 20          # blocks a sampling job may have
SAMPLING_TOP = 64                      # largest |f| a block keeps
# One block's sums in SESSION_PART_SUMS, and in memory as a numpy record:
# qmc_sampling_sums (qmc/sampling.h) without the block number.
PART_RECORD = np.dtype([
    ("count", "<u4"), ("nonfinite", "<u4"), ("f", "<f8", (2,)), ("absf", "<f8", (2,)),
    ("g", "<f8", (2,)), ("mean_f", "<f8"), ("mean_g", "<f8"), ("m2_f", "<f8"),
    ("m2_g", "<f8"), ("c_fg", "<f8"), ("top", "<f8", (SAMPLING_TOP,))])
PART_SUMS_BYTES = PART_RECORD.itemsize          # 608
PART_MAX_SUMS = (1 << 20) // PART_SUMS_BYTES    # 1724 a frame: 1 MiB of records


def part_range(blocks, k, p):
    """Part k of p of a job of `blocks` blocks: (first, count), blocks
    [blocks (k-1) / p, blocks k / p) as `qmc integrate --part` takes them."""
    first = blocks * (k - 1) // p
    return first, blocks * k // p - first


def part_records(raw):
    """The records of a SESSION_PART_SUMS (its "records" bytes) as a
    numpy array of PART_RECORD, a view of raw."""
    return np.frombuffer(raw, dtype=PART_RECORD)


def check_session_part(d):
    b, k, p = d["blocks"], d["part_k"], d["part_p"]
    if not 1 <= b <= SAMPLING_MAX_BLOCKS or not 1 <= k <= p:
        return "part %d of %d of a job of %d blocks" % (k, p, b)
    if (d["first"], d["count"]) != part_range(b, k, p):
        return "blocks %d + %d are not part %d of %d of %d blocks" % (
            d["first"], d["count"], k, p, b)
    if not math.isfinite(d["sampling"]["confidence"]):
        return "confidence is not finite"
    return None


def check_part_sums(d):
    n, first = d["n"], d["first"]
    if not 1 <= n <= PART_MAX_SUMS or first >= SAMPLING_MAX_BLOCKS or \
            n > SAMPLING_MAX_BLOCKS - first:
        return "%d block sums from block %d" % (n, first)
    raw = d.get("records", b"")
    if len(raw) != n * PART_SUMS_BYTES:
        return "%d block sums in %d bytes" % (n, len(raw))
    r = part_records(raw)
    if np.any(r["count"] > SAMPLING_BLOCK) or np.any(r["nonfinite"] > r["count"]):
        return "a block of more than %d points, or more non-finite than points" \
            % SAMPLING_BLOCK
    top = r["top"]
    # Non-negative and descending: a NaN fails both.
    if not (np.all(top >= 0.0) and np.all(top[:, 1:] <= top[:, :-1])):
        return "a block's largest values are negative, NaN or not descending"
    return None
