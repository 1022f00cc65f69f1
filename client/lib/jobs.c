/*
 * jobs.c - INTEGRATE and its family: submit (INTEGRATE -> JOB_ACCEPTED),
 * the result that arrives later on the INTEGRATE's request id
 * (JOB_RESULT or ERROR), JOB_STATUS, JOB_CANCEL, and the blocking
 * integrate built from them.
 *
 * A job's result may arrive while the client waits for something else (a
 * PONG, another job's state); it is then filed in the job's slot, so the
 * table of unfinished jobs is the only state kept between calls.  Must
 * not: grow that table past QMC_CLIENT_MAX_JOBS, or lose a result that
 * arrived before it was asked for.
 */
#include <errno.h>
#include <string.h>

#include "client_impl.h"

static qmc__client_job *find_by_request(qmc_client *c, uint64_t request_id)
{
    for (uint32_t i = 0; i < QMC_CLIENT_MAX_JOBS; i++)
        if (c->jobs[i].used && c->jobs[i].request_id == request_id)
            return &c->jobs[i];
    return NULL;
}

static qmc__client_job *find_by_id(qmc_client *c, uint64_t job_id)
{
    for (uint32_t i = 0; i < QMC_CLIENT_MAX_JOBS; i++)
        if (c->jobs[i].used && c->jobs[i].job_id == job_id)
            return &c->jobs[i];
    return NULL;
}

void qmc__client_copy_result(qmc_client_result *r, const qmc_msg_job_result *m)
{
    memset(r, 0, sizeof *r);
    r->job_id = m->job_id;
    r->res = m->res;
    r->cv = m->cv;
    r->method_used = m->method_used;
    r->sampling = m->sampling;
    r->seconds = m->seconds;
    r->reference_kind = m->reference_kind;
    r->reference = m->reference;
    r->has_known_abs = m->has_known_abs;
    r->known_abs = m->known_abs;
    qmc__client_copy_str(r->detail, sizeof r->detail, m->detail);
    qmc__client_copy_str(r->auto_reason, sizeof r->auto_reason, m->auto_reason);
}

int qmc__client_file_job(qmc_client *c, const qmc_msg *msg)
{
    qmc__client_job *j = find_by_request(c, msg->request_id);
    if (!j || j->finished)
        return 0;
    switch (msg->type) {
    case QMC_MSG_JOB_PROGRESS:
        return 1;
    case QMC_MSG_JOB_RESULT:
        if (msg->u.result.job_id != j->job_id)
            return qmc__client_break(c, QMC_EPROTO, "protocol error: JOB_RESULT for job "
                                     "%llu on the request of job %llu",
                                     (unsigned long long)msg->u.result.job_id,
                                     (unsigned long long)j->job_id);
        qmc__client_copy_result(&j->result, &msg->u.result);
        j->finished = 1;
        return 1;
    case QMC_MSG_ERROR:
        j->err = msg->u.error.code < 0 ? msg->u.error.code : QMC_EPROTO;
        qmc__client_copy_str(j->message, sizeof j->message, msg->u.error.message);
        if (j->message[0] == '\0')
            qmc__client_copy_str(j->message, sizeof j->message,
                                 (qmc_str){qmc_strerror(j->err),
                                           (uint32_t)strlen(qmc_strerror(j->err))});
        j->finished = 1;
        return 1;
    default:
        return 0;
    }
}

int qmc_client_submit(qmc_client *c, const qmc_job_spec *spec, uint64_t *job_id)
{
    *job_id = 0;
    int err = qmc__client_ready(c);
    if (err)
        return err;
    if (!spec)
        return qmc__client_fail(c, QMC_EINVAL, "integrate: no job spec");
    qmc__client_job *slot = NULL;
    uint32_t in_use = 0;
    for (uint32_t i = 0; i < QMC_CLIENT_MAX_JOBS; i++) {
        if (c->jobs[i].used)
            in_use++;
        else if (!slot)
            slot = &c->jobs[i];
    }
    if (!slot || in_use >= c->max_jobs)
        return qmc__client_fail(c, QMC_ETOOBIG, "integrate: this client already has %u "
                                "unfinished jobs (wait for one first)", in_use);
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_INTEGRATE;
    qmc_msg_integrate *in = &m.u.integrate;
    in->spec = *spec;
    in->spec.a = in->spec.u = NULL;
    in->spec.scene_text = NULL;
    in->a.values = spec->a;
    in->a.count = spec->a ? spec->n_a : 0;
    in->u.values = spec->u;
    in->u.count = spec->u ? spec->n_u : 0;
    in->scene.ptr = spec->scene_text;
    in->scene.len = spec->scene_text ? spec->scene_len : 0;
    in->progress_ms = 0;
    uint64_t id;
    if ((err = qmc__client_send(c, &m, &id)) != 0)
        return err;
    if ((err = qmc__client_await(c, id, qmc__client_deadline(c), 0, &m)) != 0)
        return err;
    if (m.type == QMC_MSG_ERROR)
        return qmc__client_server_error(c, &m);
    if (m.type != QMC_MSG_JOB_ACCEPTED)
        return qmc__client_break(c, QMC_EPROTO, "protocol error: %s instead of "
                                 "JOB_ACCEPTED", qmc_msg_type_name(m.type));
    if (find_by_id(c, m.u.job.job_id))
        return qmc__client_break(c, QMC_EPROTO, "protocol error: job id %llu given twice",
                                 (unsigned long long)m.u.job.job_id);
    memset(slot, 0, sizeof *slot);
    slot->used = 1;
    slot->request_id = id;
    slot->job_id = m.u.job.job_id;
    *job_id = slot->job_id;
    c->message[0] = '\0';
    return 0;
}

/* JOB_STATUS for job_id, answered by JOB_STATE (or ERROR). */
static int status(qmc_client *c, uint64_t job_id, qmc_msg *m)
{
    memset(m, 0, sizeof *m);
    m->type = QMC_MSG_JOB_STATUS;
    m->u.job.job_id = job_id;
    uint64_t id;
    int err = qmc__client_send(c, m, &id);
    if (err == 0)
        err = qmc__client_await(c, id, qmc__client_deadline(c), 0, m);
    if (err)
        return err;
    if (m->type == QMC_MSG_ERROR)
        return qmc__client_server_error(c, m);
    if (m->type != QMC_MSG_JOB_STATE || m->u.state.job_id != job_id)
        return qmc__client_break(c, QMC_EPROTO, "protocol error: %s instead of "
                                 "JOB_STATE for job %llu", qmc_msg_type_name(m->type),
                                 (unsigned long long)job_id);
    return 0;
}

int qmc_client_poll(qmc_client *c, uint64_t job_id, qmc_job_state *state,
                    uint64_t *evals)
{
    *state = QMC_JOB_UNKNOWN;
    *evals = 0;
    int err = qmc__client_ready(c);
    if (err)
        return err;
    qmc_msg m;
    if ((err = status(c, job_id, &m)) != 0)
        return err;
    *state = m.u.state.state;
    *evals = m.u.state.evals;
    return 0;
}

int qmc_client_cancel(qmc_client *c, uint64_t job_id)
{
    int err = qmc__client_ready(c);
    if (err)
        return err;
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_JOB_CANCEL;
    m.u.job.job_id = job_id;
    uint64_t id;
    if ((err = qmc__client_send(c, &m, &id)) != 0 ||
        (err = qmc__client_await(c, id, qmc__client_deadline(c), 0, &m)) != 0)
        return err;
    if (m.type == QMC_MSG_ERROR)
        return qmc__client_server_error(c, &m);
    if (m.type != QMC_MSG_JOB_STATE)
        return qmc__client_break(c, QMC_EPROTO, "protocol error: %s instead of "
                                 "JOB_STATE after JOB_CANCEL", qmc_msg_type_name(m.type));
    return 0;
}

static int64_t earlier(int64_t a, int64_t b)
{
    if (a < 0)
        return b;
    if (b < 0)
        return a;
    return a < b ? a : b;
}

int qmc_client_wait(qmc_client *c, uint64_t job_id, int timeout_ms,
                    qmc_client_result *out)
{
    memset(out, 0, sizeof *out);
    int err = qmc__client_ready(c);
    if (err)
        return err;
    qmc__client_job *j = find_by_id(c, job_id);
    if (!j)
        return qmc__client_fail(c, QMC_EINVAL, "job %llu is not one this client waits for",
                                (unsigned long long)job_id);
    const int64_t until = timeout_ms < 0 ? -1 : qmc__client_now_ms() + timeout_ms;
    while (!j->finished) {
        qmc_msg m;
        err = qmc__client_read(c, earlier(until, qmc__client_deadline(c)), 1, &m);
        if (err == -ETIMEDOUT) {
            if (until >= 0 && qmc__client_now_ms() >= until)
                return qmc__client_fail(c, err, "job %llu: no result within %d ms",
                                        (unsigned long long)job_id, timeout_ms);
            /* Quiet for a whole timeout: make sure the server is alive.
             * A dead one fails this and closes the connection. */
            if ((err = status(c, job_id, &m)) != 0)
                return err;
            continue;
        }
        if (err)
            return err;
        if ((err = qmc__client_other(c, &m, j->request_id)) != 0)
            return err;
    }
    err = j->err;
    if (err) {
        memcpy(c->message, j->message, sizeof j->message);
    } else {
        *out = j->result;
        c->message[0] = '\0';
    }
    memset(j, 0, sizeof *j);
    return err;
}

int qmc_client_integrate(qmc_client *c, const qmc_job_spec *spec, qmc_client_result *out)
{
    memset(out, 0, sizeof *out);
    uint64_t job_id;
    int err = qmc_client_submit(c, spec, &job_id);
    if (err == 0)
        err = qmc_client_wait(c, job_id, -1, out);
    return err;
}
