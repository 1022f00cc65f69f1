/*
 * modbus_rtu.c - Modbus RTU on a serial line, through libmodbus: it does
 * the termios set-up, the CRC and the inter-frame timing, which is what it
 * is good at.  A serial line has one master, so a line gets one thread
 * that waits for a frame, answers it and waits again.
 *
 * Why the thread calls the pure handler itself instead of handing frames
 * to the loop: the handler touches only the session (this line's register
 * bank, owned by this thread alone) and an env snapshot of the counters,
 * which are atomics; it never reads the loop's connections, jobs or the
 * configuration a SIGHUP replaces (everything this file needs is copied at
 * open, the integration memory caps included: a line keeps the caps it
 * started with until a restart).  So no lock is needed and a busy loop
 * never delays a serial reply past the master's timeout.  Its bank's
 * integration memory counts against modbus-integration-memory-total
 * through the atomics; a start on the line and one on TCP at the same
 * moment may both fit the room each saw, so the total can be passed by
 * at most one bank's cap per line.
 *
 * The thread waits in poll() on the line and on an eventfd, so stopping
 * it is a write to the eventfd, not a pthread_cancel inside libmodbus.
 * libmodbus filters frames by unit id: the line answers its UNIT (default
 * 1) and applies broadcasts (unit 0) without replying, as the serial line
 * spec requires.  libmodbus 3.1.6 cannot frame FC43 requests on RTU (it
 * does not know their length), so FC43 is served on TCP only.
 *
 * Must not: interpret registers, or touch any loop state but the atomics.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <modbus.h>
#include <poll.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include "log.h"
#include "modbus_srv.h"

struct qmcd_mb_rtu {
    qmcd_modbus *mb;
    qmcd_modbus_rtu_spec spec;
    char name[QMCD_PATH_BYTES + 32];
    modbus_t *ctx;
    qmc_modbus_session *sess;
    qmc_modbus_usage usage;      /* its integration's, as last counted */
    uint64_t integ_bytes, integ_total; /* the caps, copied at open */
    int stop_fd;                 /* eventfd: readable means stop */
    pthread_t thread;
    int started;
};

const char *qmcd__modbus_rtu_name(const qmcd_mb_rtu *rtu)
{
    return rtu->name;
}

int qmcd__modbus_rtu_open(qmcd_modbus *mb, const qmcd_modbus_rtu_spec *spec, qmcd_mb_rtu **out,
                          char *why, size_t why_bytes)
{
    *out = NULL;
    qmcd_mb_rtu *r = calloc(1, sizeof *r);
    if (!r) {
        snprintf(why, why_bytes, "modbus rtu: out of memory");
        return -1;
    }
    r->mb = mb;
    r->spec = *spec;
    r->integ_bytes = mb->srv->cfg.modbus_integration_memory;
    r->integ_total = mb->srv->cfg.modbus_integration_memory_total;
    r->stop_fd = -1;
    snprintf(r->name, sizeof r->name, "rtu:%s:%d:%c:%d:%d:%d%s", spec->device, spec->baud,
             spec->parity, spec->data_bits, spec->stop_bits, spec->unit,
             spec->rs485 ? ":rs485" : "");
    if (qmc_modbus_session_new(&r->sess) != 0) {
        snprintf(why, why_bytes, "modbus %s: out of memory", r->name);
        goto fail;
    }
    r->stop_fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    if (r->stop_fd < 0) {
        snprintf(why, why_bytes, "modbus %s: eventfd: %s", r->name, strerror(errno));
        goto fail;
    }
    r->ctx = modbus_new_rtu(spec->device, spec->baud, spec->parity, spec->data_bits,
                            spec->stop_bits);
    if (!r->ctx) {
        snprintf(why, why_bytes, "modbus %s: %s", r->name, modbus_strerror(errno));
        goto fail;
    }
    if (modbus_set_slave(r->ctx, spec->unit) != 0 || modbus_connect(r->ctx) != 0) {
        snprintf(why, why_bytes, "modbus %s: cannot open the line: %s", r->name,
                 modbus_strerror(errno));
        goto fail;
    }
    /* RS-485 half duplex: the UART's driver switches the transceiver's
     * direction (TIOCSRS485); libmodbus only asks for it.  A line whose
     * driver cannot (a USB adapter that does it in hardware, a pty) says
     * so here rather than failing on the first answer. */
    if (spec->rs485 && modbus_rtu_set_serial_mode(r->ctx, MODBUS_RTU_RS485) != 0) {
        snprintf(why, why_bytes, "modbus %s: the line does not take RS-485 mode "
                 "(TIOCSRS485: %s); drop ':rs485' if the adapter switches by itself",
                 r->name, modbus_strerror(errno));
        goto fail;
    }
    *out = r;
    return 0;
fail:
    qmcd__modbus_rtu_free(r);
    return -1;
}

/* Answers one frame adu[0 .. n): unit, PDU, CRC (already checked). */
static void answer(qmcd_mb_rtu *r, const uint8_t *adu, int n)
{
    int header = modbus_get_header_length(r->ctx); /* 1: the unit id */
    int pdu_len = n - header - 2;
    if (pdu_len < 1)
        return;
    qmc_modbus_env env;
    qmcd__modbus_env(r->mb, &env);
    /* A line is one device: its room is the bank's cap and what the
     * others leave of the total (no peer share). */
    env.integration_bytes_max = qmcd__modbus_room(r->mb, r->integ_bytes, r->integ_total,
                                                  r->usage.integration_bytes, UINT64_MAX);
    uint8_t raw[1 + QMC_MODBUS_MAX_PDU];
    int m = qmc_modbus_handle(r->sess, &env, adu + header, (size_t)pdu_len, raw + 1,
                              QMC_MODBUS_MAX_PDU);
    qmcd__modbus_account(r->mb, &r->usage, r->sess);
    if (m <= 0)
        return;
    qmcd__modbus_count(r->mb, raw + 1);
    if (adu[0] == 0)
        return; /* broadcast: applied, never answered */
    raw[0] = adu[0];
    /* Sends unit + PDU with the CRC appended: libmodbus only frames it. */
    if (modbus_send_raw_request(r->ctx, raw, 1 + m) < 0)
        qmcd_warn("modbus %s: send: %s", r->name, modbus_strerror(errno));
}

static void *serve(void *arg)
{
    qmcd_mb_rtu *r = arg;
    uint8_t adu[MODBUS_RTU_MAX_ADU_LENGTH];
    struct pollfd pf[2] = {{.fd = modbus_get_socket(r->ctx), .events = POLLIN},
                           {.fd = r->stop_fd, .events = POLLIN}};
    for (;;) {
        if (poll(pf, 2, -1) < 0) {
            if (errno == EINTR)
                continue;
            qmcd_err("modbus %s: poll: %s; the line stops serving", r->name, strerror(errno));
            break;
        }
        if (pf[1].revents)
            break;
        if (pf[0].revents & (POLLERR | POLLNVAL | POLLHUP)) {
            qmcd_err("modbus %s: the line failed; it stops serving", r->name);
            break;
        }
        if (!(pf[0].revents & POLLIN))
            continue;
        /* The first byte is here: libmodbus reads the rest of the frame
         * with its byte timeout and checks the CRC and the unit id. */
        int n = modbus_receive(r->ctx, adu);
        if (n > 0) {
            answer(r, adu, n);
        } else if (n < 0) {
            /* A bad CRC or a frame cut short: drop what is left of it so
             * the next request starts clean. */
            atomic_fetch_add_explicit(&r->mb->ctr.malformed, 1, memory_order_relaxed);
            qmcd_debug("modbus %s: dropped a frame: %s", r->name, modbus_strerror(errno));
            (void)modbus_flush(r->ctx);
        }
        /* n == 0: a frame for another unit; libmodbus ignored it. */
    }
    return NULL;
}

int qmcd__modbus_rtu_start(qmcd_mb_rtu *r)
{
    int err = pthread_create(&r->thread, NULL, serve, r);
    if (err)
        return -err;
    r->started = 1;
    return 0;
}

void qmcd__modbus_rtu_free(qmcd_mb_rtu *r)
{
    if (!r)
        return;
    if (r->started) {
        uint64_t one = 1;
        if (write(r->stop_fd, &one, sizeof one) != (ssize_t)sizeof one)
            qmcd_warn("modbus %s: cannot signal the thread to stop", r->name);
        pthread_join(r->thread, NULL);
    }
    if (r->ctx) {
        modbus_close(r->ctx);
        modbus_free(r->ctx);
    }
    if (r->stop_fd >= 0)
        close(r->stop_fd);
    if (r->sess)
        qmcd__modbus_account(r->mb, &r->usage, NULL);
    qmc_modbus_session_free(r->sess);
    free(r);
}
