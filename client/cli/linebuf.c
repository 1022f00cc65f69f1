/*
 * linebuf.c - lines out of a stream fed in pieces (see linebuf.h).  Must
 * not: read a file, keep more than one capped line, or pass on a line with
 * a NUL byte inside (C string functions would cut it short unseen).
 */
#include "linebuf.h"

#include <stdlib.h>
#include <string.h>

int cli_linebuf_init(cli_linebuf *lb, size_t max_bytes)
{
    lb->len = 0;
    lb->max_bytes = max_bytes;
    lb->buf = malloc(max_bytes + 1);
    return lb->buf ? CLI_LINE_OK : CLI_LINE_NOMEM;
}

void cli_linebuf_close(cli_linebuf *lb)
{
    free(lb->buf);
    lb->buf = NULL;
    lb->len = 0;
}

int cli_linebuf_feed(cli_linebuf *lb, const char *data, size_t n, cli_line_fn on_line,
                     void *ctx)
{
    while (n > 0) {
        const char *nl = memchr(data, '\n', n);
        size_t take = nl ? (size_t)(nl - data) : n;
        /* The first bad byte decides, wherever the pieces split: a NUL
         * within the cap, else the byte past the cap. */
        size_t room = lb->max_bytes - lb->len;
        if (memchr(data, '\0', take < room ? take : room))
            return CLI_LINE_NUL;
        if (take > room)
            return CLI_LINE_TOO_LONG;
        memcpy(lb->buf + lb->len, data, take);
        lb->len += take;
        if (!nl)
            return 0;
        lb->buf[lb->len] = '\0';
        size_t len = lb->len;
        lb->len = 0;
        int r = on_line(ctx, lb->buf, len, 1);
        if (r)
            return r;
        data += take + 1;
        n -= take + 1;
    }
    return 0;
}

int cli_linebuf_end(cli_linebuf *lb, cli_line_fn on_line, void *ctx)
{
    if (lb->len == 0)
        return 0;
    lb->buf[lb->len] = '\0';
    size_t len = lb->len;
    lb->len = 0;
    return on_line(ctx, lb->buf, len, 0);
}
