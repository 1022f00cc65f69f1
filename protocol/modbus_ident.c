/*
 * modbus_ident.c - who the server is: FC17 Report Server ID and FC43/14
 * Read Device Identification (Modbus application protocol v1.1b3,
 * sections 6.13 and 6.21), built from the version and the Sobol table
 * fingerprint the transport passes in the qmc_modbus_env.
 *
 * Must not: do I/O or keep state; the answers depend on env alone.
 */
#include <string.h>

#include "modbus_pdu.h"

/* FC17's Server ID byte: 'Q'. */
#define SERVER_ID 0x51
/* Conformity level 0x81: basic identification, stream and individual
 * access (section 6.21, table of conformity levels). */
#define CONFORMITY 0x81

/* strlen capped at max (strnlen is POSIX, not C11). */
static size_t text_len(const char *s, size_t max)
{
    size_t n = 0;
    while (n < max && s[n])
        n++;
    return n;
}

static const char *version_of(const qmc_modbus_env *env)
{
    return env && env->version ? env->version : "";
}

/* "qmcd 0.1.0 sobol:0123456789abcdef" into w. */
int qmc__modbus_report_id(const qmc_modbus_env *env, qmc__mb_rd *r, qmc__mb_wr *w)
{
    if (!qmc__mb_rd_done(r))
        return QMC_MODBUS_EX_ILLEGAL_VALUE;
    static const char hex[] = "0123456789abcdef";
    const char *v = version_of(env);
    size_t vlen = text_len(v, 64);
    char fp[16];
    uint64_t h = env ? env->sobol_table_hash : 0;
    for (int i = 0; i < 16; i++)
        fp[i] = hex[(h >> (60 - 4 * i)) & 15];
    size_t data = 2 + 5 + vlen + 7 + sizeof fp; /* id, run, "qmcd ", v, " sobol:", fp */
    qmc__mb_put_u8(w, QMC_MODBUS_FC_REPORT_SERVER_ID);
    qmc__mb_put_u8(w, (uint8_t)data);
    qmc__mb_put_u8(w, SERVER_ID);
    qmc__mb_put_u8(w, 0xFF); /* run indicator: on */
    qmc__mb_put_bytes(w, "qmcd ", 5);
    qmc__mb_put_bytes(w, v, vlen);
    qmc__mb_put_bytes(w, " sobol:", 7);
    qmc__mb_put_bytes(w, fp, sizeof fp);
    return 0;
}

/* The basic objects: 0 VendorName, 1 ProductCode, 2 MajorMinorRevision. */
enum { N_OBJECTS = 3 };

static const char *object(const qmc_modbus_env *env, unsigned id)
{
    switch (id) {
    case 0:
        return "qmcd";
    case 1:
        return "qmcd-modbus";
    default:
        return version_of(env);
    }
}

/*
 * Read codes 1..3 (basic, regular, extended stream) stream every object we
 * have from the asked-for one on; an unknown start restarts at object 0,
 * as section 6.21 says.  Code 4 reads one object; an unknown one is 02.
 */
int qmc__modbus_device_id(const qmc_modbus_env *env, qmc__mb_rd *r, qmc__mb_wr *w)
{
    uint8_t mei = qmc__mb_u8(r);
    if (!r->bad && mei != QMC_MODBUS_MEI_DEVICE_ID)
        return QMC_MODBUS_EX_ILLEGAL_FUNCTION; /* e.g. MEI 13, CANopen */
    uint8_t code = qmc__mb_u8(r), id = qmc__mb_u8(r);
    if (!qmc__mb_rd_done(r) || code < 1 || code > 4)
        return QMC_MODBUS_EX_ILLEGAL_VALUE;
    unsigned first = id, last = id;
    if (code == 4) {
        if (id >= N_OBJECTS)
            return QMC_MODBUS_EX_ILLEGAL_ADDRESS;
    } else {
        first = id < N_OBJECTS ? id : 0;
        last = N_OBJECTS - 1;
    }
    qmc__mb_put_u8(w, QMC_MODBUS_FC_ENCAPSULATED);
    qmc__mb_put_u8(w, QMC_MODBUS_MEI_DEVICE_ID);
    qmc__mb_put_u8(w, code);
    qmc__mb_put_u8(w, CONFORMITY);
    qmc__mb_put_u8(w, 0x00); /* more follows: no, everything fits */
    qmc__mb_put_u8(w, 0x00); /* next object id */
    qmc__mb_put_u8(w, (uint8_t)(last - first + 1));
    for (unsigned k = first; k <= last; k++) {
        const char *s = object(env, k);
        size_t n = text_len(s, 64);
        qmc__mb_put_u8(w, (uint8_t)k);
        qmc__mb_put_u8(w, (uint8_t)n);
        qmc__mb_put_bytes(w, s, n);
    }
    return 0;
}
