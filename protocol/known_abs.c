/*
 * known_abs.c - JOB_RESULT's version-6 tail (and SESSION_RESULT's, the
 * same layout): the integral of |f| the integrand knows in closed form,
 * PROTOCOL.md section 6.10.  A client judges a result's error against it
 * (`qmc integrate --json`'s abs_integral), so the daemon, which built the
 * integrand, says it, and no client keeps a copy of libqmc's rules.
 *
 * Kept apart from messages.c so that what version 6 added reads in one
 * place.  At version 5 or older the tail is not on the wire (the old
 * layout, byte for byte) and a decoded message says so: has_known_abs -1.
 * Must not: do I/O, or let through a value no integral of |f| can have.
 */
#include "codec.h"

void qmc__io_known_abs(qmc__io *io, qmc_msg_job_result *r)
{
    if (io->version < QMC_PROTO_VERSION_KNOWN_ABS) {
        if (io->decode) {
            r->has_known_abs = -1;
            r->known_abs = 0.0;
        }
        return;
    }
    /* -1 ("not told") is what a version-5 frame decodes to: it cannot be
     * passed on as an answer. */
    if (!io->decode && r->has_known_abs != 0 && r->has_known_abs != 1) {
        qmc__io_invalid(io);
        return;
    }
    qmc__io_bool(io, &r->has_known_abs);
    qmc__io_zero(io, 7);
    qmc__io_f64(io, &r->known_abs);
    if (!qmc__io_rd_ok(io))
        return;
    const double v = r->known_abs;
    /* Known: a finite integral of a non-negative function.  Unknown: the
     * value is a reserved +0. */
    if (r->has_known_abs ? !(isfinite(v) && v >= 0.0) : (v != 0.0 || signbit(v)))
        qmc__io_invalid(io);
}
