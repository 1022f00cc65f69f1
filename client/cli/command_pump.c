/*
 * command_pump.c - one batch through the --command child's pipes (see
 * command_pump.h).  Must not: block on a descriptor, write more than the
 * pipe takes at once, wait longer than the timeout without moving a
 * byte, or take a byte past a batch's values as anything but an error.
 */
#include "command_pump.h"

#include <errno.h>
#include <poll.h>
#include <stdlib.h>
#include <unistd.h>

#include "cli.h"

enum { PUMP_BUF_BYTES = 1 << 16 };

int cli_pump_init(cli_pump *p, cli_cmd_format format, uint32_t dims)
{
    size_t need = cli_cmd_enc_min_bytes(format, dims);
    p->out_cap = need > PUMP_BUF_BYTES ? need : PUMP_BUF_BYTES;
    p->in_cap = PUMP_BUF_BYTES;
    p->out_off = p->out_len = 0;
    p->sys_errno = 0;
    p->out = malloc(p->out_cap);
    p->in = malloc(p->in_cap);
    if (!p->out || !p->in) {
        cli_pump_close(p);
        return -1;
    }
    return 0;
}

void cli_pump_close(cli_pump *p)
{
    free(p->out);
    free(p->in);
    p->out = p->in = NULL;
}

/* Milliseconds left until last + timeout (timeout 0: -1, for ever). */
static int remaining_ms(double last, int timeout_ms)
{
    if (timeout_ms <= 0)
        return -1;
    double left = last + timeout_ms / 1000.0 - cli_now_seconds();
    return left <= 0 ? 0 : (int)(left * 1000.0) + 1;
}

/* Writes what the pipe takes.  1 if a byte moved, 0 if none, -1 for
 * EPIPE (the read end is closed), -2 for another error. */
static int write_some(cli_pump *p, cli_child *c, cli_cmd_enc *e)
{
    int moved = 0;
    for (;;) {
        if (p->out_off == p->out_len) {
            p->out_off = 0;
            p->out_len = cli_cmd_enc_fill(e, p->out, p->out_cap);
            if (p->out_len == 0)
                return moved;
        }
        ssize_t w = write(c->to_fd, p->out + p->out_off, p->out_len - p->out_off);
        if (w > 0) {
            p->out_off += (size_t)w;
            moved = 1;
        } else if (w < 0 && errno == EINTR) {
            continue;
        } else if (w < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
            return moved;
        } else if (w < 0 && errno == EPIPE) {
            return -1;
        } else {
            p->sys_errno = w < 0 ? errno : EIO;
            return -2;
        }
    }
}

/* Reads what has come into d.  1 if a byte moved, 0 if none, -1 at the
 * end of the output, -2 for an error; d's status says what it made of
 * the bytes. */
static int read_some(cli_pump *p, cli_child *c, cli_cmd_dec *d)
{
    int moved = 0;
    for (;;) {
        ssize_t r = read(c->from_fd, p->in, p->in_cap);
        if (r > 0) {
            moved = 1;
            if (cli_cmd_dec_feed(d, p->in, (size_t)r) < 0)
                return moved;
        } else if (r == 0) {
            return -1;
        } else if (errno == EINTR) {
            continue;
        } else if (errno == EAGAIN || errno == EWOULDBLOCK) {
            return moved;
        } else {
            p->sys_errno = errno;
            return -2;
        }
    }
}

cli_pump_end cli_pump_batch(cli_pump *p, cli_child *c, cli_cmd_enc *e, cli_cmd_dec *d,
                            int timeout_ms)
{
    p->out_off = p->out_len = 0;
    p->epipe = c->to_fd < 0;
    double last = cli_now_seconds();
    for (;;) {
        if (d->status < 0)
            return CLI_PUMP_BAD;
        int sent = cli_cmd_enc_done(e) && p->out_off == p->out_len;
        /* All values in: done once every byte is out - or the program
         * stopped reading after answering everything, which only the
         * batch's trailer can have missed.  A program that stopped
         * reading before is heard out: its output ends (EOF, with the
         * values it gave) or the timeout passes. */
        if (d->status == CLI_CMD_DONE && (sent || p->epipe))
            return CLI_PUMP_OK;
        struct pollfd f[2];
        nfds_t n = 0;
        if (!sent && !p->epipe)
            f[n++] = (struct pollfd){c->to_fd, POLLOUT, 0};
        f[n++] = (struct pollfd){c->from_fd, POLLIN, 0};
        int wait = remaining_ms(last, timeout_ms);
        if (wait == 0)
            return CLI_PUMP_TIMEOUT;
        int r = poll(f, n, wait);
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0) {
            p->sys_errno = errno;
            return CLI_PUMP_SYS;
        }
        for (nfds_t i = 0; i < n; i++) {
            if (!f[i].revents)
                continue;
            int m = f[i].fd == c->to_fd ? write_some(p, c, e) : read_some(p, c, d);
            if (m == -2)
                return CLI_PUMP_SYS;
            if (m == -1 && f[i].fd == c->to_fd) {
                p->epipe = 1;
                cli_child_close_input(c);
            } else if (m == -1) {
                if (d->status < 0 || cli_cmd_dec_end(d) < 0)
                    return CLI_PUMP_BAD;
                if (d->status == CLI_CMD_DONE && (sent || cli_cmd_enc_done(e)))
                    return CLI_PUMP_OK; /* it ended right after its last value */
                return CLI_PUMP_EOF;
            } else if (m == 1) {
                last = cli_now_seconds();
            }
            break; /* the descriptors may have changed: poll again */
        }
    }
}

cli_pump_end cli_pump_drain(cli_pump *p, cli_child *c, cli_cmd_dec *d, int timeout_ms)
{
    cli_child_close_input(c);
    double last = cli_now_seconds();
    for (;;) {
        int wait = remaining_ms(last, timeout_ms);
        if (wait == 0)
            return CLI_PUMP_TIMEOUT;
        struct pollfd f = {c->from_fd, POLLIN, 0};
        int r = poll(&f, 1, wait);
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0) {
            p->sys_errno = errno;
            return CLI_PUMP_SYS;
        }
        if (r == 0)
            continue;
        int m = read_some(p, c, d);
        if (d->status < 0)
            return CLI_PUMP_BAD;
        if (m == -2)
            return CLI_PUMP_SYS;
        if (m == -1)
            return cli_cmd_dec_end(d) < 0 ? CLI_PUMP_BAD : CLI_PUMP_OK;
        if (m == 1)
            last = cli_now_seconds();
    }
}
