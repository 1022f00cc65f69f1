/*
 * msg_version.c - the oldest protocol version that can carry a message.
 *
 * A field value that came with a later version (scramble 4, fast-owen,
 * came with version 4) is a malformed frame to a server built before it,
 * which closes the connection.  A client asks this before it sends, so it
 * can refuse with a reason instead (libqmcclient does, in one place).
 * Pure: no I/O.
 */
#include "qmc/proto.h"

unsigned qmc_proto_msg_min_version(const qmc_msg *msg)
{
    switch (msg->type) {
    case QMC_MSG_SHM_ATTACH:
    case QMC_MSG_SHM_RELEASE:
        return QMC_PROTO_VERSION_SHM;
    case QMC_MSG_AUTH_RESPONSE:
        return QMC_PROTO_VERSION_AUTH;
    case QMC_MSG_PIXELS:
        return QMC_PROTO_VERSION_PIXELS;
    case QMC_MSG_SESSION_OPEN:
        return msg->u.session_open.spec.part_p || msg->u.session_open.spec.part_k
                   ? QMC_PROTO_VERSION_PARTS : QMC_PROTO_VERSION_SESSIONS;
    case QMC_MSG_SESSION_PART:
    case QMC_MSG_SESSION_PART_SUMS:
        return QMC_PROTO_VERSION_PARTS;
    case QMC_MSG_SESSION_VALUES:
    case QMC_MSG_SESSION_RESUME:
    case QMC_MSG_SESSION_CLOSE:
        return QMC_PROTO_VERSION_SESSIONS;
    case QMC_MSG_POINTS:
        return msg->u.points.seq.scramble == QMC_SCRAMBLE_FAST_OWEN
                   ? QMC_PROTO_VERSION_FAST_OWEN : 1u;
    case QMC_MSG_INTEGRATE:
        return msg->u.integrate.spec.integrate.sampling.scramble == QMC_SCRAMBLE_FAST_OWEN
                   ? QMC_PROTO_VERSION_FAST_OWEN : 1u;
    default:
        return 1u;
    }
}
