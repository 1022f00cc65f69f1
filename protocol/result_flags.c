/*
 * result_flags.c - which result flag bits each protocol version defines,
 * and how a result's flags are told to a peer of an older version
 * (PROTOCOL.md section 5).
 *
 * Versions 1 and 2 define bits 0-11; version 3 adds bits 12-16
 * (few_nonzero, zero_spread, tail_untested, unresolved, mis_undersampled);
 * versions 4, 5 and 6 define the same bits as version 3.
 * A peer rejects a frame with a flag bit its version does not define, so
 * a daemon that sent bits 12-16 to a client built before them would break
 * it.  Instead the bits are dropped for such a peer and error_unreliable,
 * which every version defines, carries what they meant to it: the bar
 * cannot be trusted.  Most of them set error_unreliable in the engine
 * already; tail_untested does not (a bar whose tail could not be tested
 * is printed with that flag beside it), and few_nonzero does not on a
 * result with no bar.  Dropped silently, they would leave an older peer a
 * bare bar that a newer one sees flagged, so dropping one raises it.
 *
 * Pure: no I/O, no state.
 */
#include "qmc/proto.h"
#include "qmc/result.h"

#define FLAG_BIT(name, bit, ...) | (1u << (bit))

/* Every bit this build defines (qmc/result.h).  A bit added there must be
 * given a protocol version here: the check below fails to compile until
 * it is. */
#define RESULT_FLAGS_ALL (0u QMC_FLAG_MAP(FLAG_BIT))
_Static_assert(RESULT_FLAGS_ALL == QMC_PROTO_RESULT_FLAGS_V3,
               "a result flag without a protocol version (PROTOCOL.md section 5)");
/* Versions 4 (PIXELS), 5 (sessions) and 6 (the known integral of |f|,
 * part sessions) added no flag bits: they define version 3's.  A new
 * version must say here which bits it defines. */
_Static_assert(QMC_PROTO_VERSION_MAX == QMC_PROTO_VERSION_KNOWN_ABS &&
               QMC_PROTO_VERSION_MAX == QMC_PROTO_VERSION_PARTS,
               "a protocol version without its result flag bits");
_Static_assert((QMC_PROTO_RESULT_FLAGS_V1 & QMC_FLAG_ERROR_UNRELIABLE) != 0,
               "the oldest version must carry error_unreliable");

uint32_t qmc_proto_result_flags_defined(unsigned version)
{
    if (version == 0 || version > QMC_PROTO_VERSION_MAX)
        return 0;
    return version < QMC_PROTO_VERSION_FLAGS3 ? QMC_PROTO_RESULT_FLAGS_V1
                                              : QMC_PROTO_RESULT_FLAGS_V3;
}

uint32_t qmc_proto_result_flags_for(unsigned version, uint32_t flags)
{
    const uint32_t defined = qmc_proto_result_flags_defined(version);
    if (defined == 0)
        return flags;
    const uint32_t dropped = flags & RESULT_FLAGS_ALL & ~defined;
    if (dropped == 0)
        return flags;
    return (flags & ~dropped) | QMC_FLAG_ERROR_UNRELIABLE;
}
