/*
 * auth.c - the client's half of the version-3 authenticated handshake
 * (PROTOCOL.md section 4.1): reading the key file (the same rule as the
 * daemon's: mode 0600 or stricter, 16 to 1024 bytes), answering the
 * server's AUTH_CHALLENGE, and checking the server's proof in AUTH_OK.
 *
 * The MACs and comparisons are protocol/auth.c's (libsodium); the nonce
 * comes from libsodium's generator.  Must not: print, or keep a key in
 * memory the client does not own (it is wiped at close).
 */
#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <sodium.h>

#include "client_impl.h"
#include "qmc/auth.h"

/* What a file that is not regular is, for the error line. */
static const char *file_kind(mode_t mode)
{
    if (S_ISFIFO(mode))
        return "a FIFO";
    if (S_ISDIR(mode))
        return "a directory";
    if (S_ISCHR(mode))
        return "a character device";
    if (S_ISBLK(mode))
        return "a block device";
    if (S_ISSOCK(mode))
        return "a socket";
    return "of an unknown type";
}

/* Opens the key file only if it is a regular file, never waiting: before
 * issue 22, --auth-key naming a FIFO hung qmc (and any program connecting
 * with $QMC_AUTH_KEY_FILE) in open() until someone wrote to it.  A FIFO or
 * a device is refused before it is opened (opening a device can act on
 * its own); the open is non-blocking, so a name swapped for a FIFO since
 * the stat returns at once and the fstat refuses it.  The descriptor, or
 * a negative code with c->message set: QMC_EAUTH for a file that is not
 * regular, -errno otherwise. */
static int open_regular(qmc_client *c, const char *path)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return qmc__client_fail(c, -errno, "auth key %s: cannot open: %s", path,
                                strerror(errno));
    if (!S_ISREG(st.st_mode))
        return qmc__client_fail(c, QMC_EAUTH, "auth key %s: is %s, not a regular file", path,
                                file_kind(st.st_mode));
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0)
        return qmc__client_fail(c, -errno, "auth key %s: cannot open: %s", path,
                                strerror(errno));
    int flags;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || (flags = fcntl(fd, F_GETFL)) < 0 ||
        fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) != 0) {
        int err = S_ISREG(st.st_mode) ? -errno : QMC_EAUTH;
        close(fd);
        if (err == QMC_EAUTH)
            return qmc__client_fail(c, err, "auth key %s: is %s, not a regular file", path,
                                    file_kind(st.st_mode));
        return qmc__client_fail(c, err, "auth key %s: %s", path, strerror(-err));
    }
    return fd;
}

int qmc__client_load_key(qmc_client *c, const char *path)
{
    int fd = open_regular(c, path);
    if (fd < 0)
        return fd;
    struct stat st;
    const char *why = NULL;
    uint8_t key[QMC_AUTH_KEY_MAX_BYTES + 1];
    size_t got = 0;
    int err = 0;
    if (fstat(fd, &st) != 0) {
        err = qmc__client_fail(c, -errno, "auth key %s: %s", path, strerror(errno));
        goto out;
    }
    if (qmc_auth_key_file_check((uint32_t)st.st_mode, (uint64_t)st.st_size, &why) != 0) {
        err = qmc__client_fail(c, QMC_EAUTH, "auth key %s %s", path, why);
        goto out;
    }
    while (got < sizeof key) {
        ssize_t r = read(fd, key + got, sizeof key - got);
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0) {
            err = qmc__client_fail(c, -errno, "auth key %s: %s", path, strerror(errno));
            goto out;
        }
        if (r == 0)
            break;
        got += (size_t)r;
    }
    if (got < QMC_AUTH_KEY_MIN_BYTES || got > QMC_AUTH_KEY_MAX_BYTES) {
        err = qmc__client_fail(c, QMC_EAUTH, "auth key %s holds %zu bytes; a key is %u to %u",
                               path, got, QMC_AUTH_KEY_MIN_BYTES, QMC_AUTH_KEY_MAX_BYTES);
        goto out;
    }
    memcpy(c->auth_key, key, got);
    c->auth_key_bytes = got;
out:
    sodium_memzero(key, sizeof key);
    close(fd);
    return err;
}

void qmc__client_wipe_key(qmc_client *c)
{
    sodium_memzero(c->auth_key, sizeof c->auth_key);
    c->auth_key_bytes = 0;
}

int qmc__client_authenticate(qmc_client *c, uint64_t hello_id, uint16_t version_min,
                             uint16_t version_max, qmc_msg *m)
{
    if (!c->auth_key_bytes)
        return qmc__client_break(c, QMC_EAUTH, "the server requires authentication: give "
                                 "its key with --auth-key FILE or QMC_AUTH_KEY_FILE");
    if (sodium_init() < 0)
        return qmc__client_break(c, -EIO, "authentication: libsodium cannot initialise");
    qmc_auth_client st;
    memset(&st, 0, sizeof st);
    uint8_t nonce[QMC_PROTO_AUTH_NONCE_BYTES];
    randombytes_buf(nonce, sizeof nonce);
    qmc_msg r;
    memset(&r, 0, sizeof r);
    r.type = QMC_MSG_AUTH_RESPONSE;
    r.request_id = hello_id;
    int err = qmc_auth_client_respond(&st, version_min, version_max, &m->u.challenge, nonce,
                                      c->auth_key, c->auth_key_bytes, &r.u.response);
    if (err)
        return qmc__client_break(c, QMC_EPROTO, "handshake failed: the server's challenge "
                                 "names protocol version %u; we offered %u..%u",
                                 m->u.challenge.version, version_min, version_max);
    const uint16_t version = st.version;
    if ((err = qmc__client_send_frame(c, &r, -1)) != 0 ||
        (err = qmc__client_await(c, hello_id, qmc__client_deadline(c), 0, m)) != 0)
        return err;
    if (m->type == QMC_MSG_ERROR) {
        err = qmc__client_server_error(c, m);
        char text[QMC_CLIENT_MESSAGE_BYTES];
        memcpy(text, c->message, sizeof text);
        return qmc__client_break(c, err, "the server refused the handshake: %s", text);
    }
    if (m->type != QMC_MSG_AUTH_OK)
        return qmc__client_break(c, QMC_EPROTO, "handshake failed: %s instead of AUTH_OK",
                                 qmc_msg_type_name(m->type));
    if (qmc_auth_client_check(&st, &m->u.auth_ok) != 0)
        return qmc__client_break(c, QMC_EAUTH, "authentication failed: the server could "
                                 "not prove it holds our key (a different key, or not "
                                 "the server we meant)");
    if ((err = qmc__client_await(c, hello_id, qmc__client_deadline(c), 0, m)) != 0)
        return err;
    if (m->type == QMC_MSG_HELLO_OK && m->u.hello_ok.version != version)
        return qmc__client_break(c, QMC_EPROTO, "handshake failed: HELLO_OK chose version "
                                 "%u after a challenge for %u", m->u.hello_ok.version,
                                 version);
    c->authenticated = 1;
    return 0;
}
