/*
 * qmc/error.h - error codes shared by every qmcd library.
 *
 * Every fallible function returns int: 0 on success, a negative QMC_E* code
 * otherwise.  System errors are passed on as -errno; the QMC codes below sit
 * far below the errno range so the two never collide.  One X-macro list
 * drives the enum, the names and the messages (libuv's UV_ERRNO_MAP habit).
 */
#ifndef QMC_ERROR_H
#define QMC_ERROR_H

#ifdef __cplusplus
extern "C" {
#endif

#define QMC_ERROR_MAP(X)                                                    \
    X(EINVAL,    -1001, "invalid argument")                                 \
    X(ENOMEM,    -1002, "out of memory")                                    \
    X(EKIND,     -1003, "unknown sequence kind")                            \
    X(ESCRAMBLE, -1004, "scramble not supported by this sequence kind")     \
    X(EDIMS,     -1005, "dimension count outside the kind's range")         \
    X(ERANGE,    -1006, "index past the end of the sequence")               \
    X(ECOUNT,    -1007, "point count not valid for this kind")              \
    X(EFORMAT,   -1008, "unknown output format")                            \
    X(EAGAIN,    -1009, "incomplete input")                                 \
    X(EPROTO,    -1010, "malformed input")                                  \
    X(ETOOBIG,   -1011, "request exceeds a configured limit")               \
    X(ENOTSUP,   -1012, "operation not supported")                          \
    X(EDOMAIN,   -1013, "value outside the function's domain")              \
    X(EBUDGET,   -1014, "evaluation budget exceeded")                       \
    X(ECANCELED, -1015, "stopped by the caller's interrupt hook")          \
    X(EAUTH,     -1016, "authentication failed")

enum {
#define QMC__ERR_ENUM(name, value, text) QMC_##name = (value),
    QMC_ERROR_MAP(QMC__ERR_ENUM)
#undef QMC__ERR_ENUM
    QMC_OK = 0
};

/* Returns a static, never-NULL message for any code, QMC or -errno. */
const char *qmc_strerror(int err);

/* Returns the symbolic name ("QMC_EDIMS", "ENOENT"), never NULL. */
const char *qmc_err_name(int err);

#if defined(__GNUC__)
#define QMC_MUST_CHECK __attribute__((warn_unused_result))
#else
#define QMC_MUST_CHECK
#endif

#ifdef __cplusplus
}
#endif
#endif /* QMC_ERROR_H */
