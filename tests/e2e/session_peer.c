/*
 * session_peer.c - the C side of tests/e2e/test_sessions.sh: integration
 * sessions through libqmcclient against a real qmcd, with qmcd's own
 * built-in integrands evaluated here (qmc_job_new builds them exactly as
 * the CLI and the daemon do), so that a session's answer can be compared
 * bit for bit with `qmc integrate --json` for the same job.
 *
 *   session-peer run ENDPOINT JOB...         qmc_client_session_run
 *   session-peer asktell ENDPOINT JOB...     next / values / tell, own loop
 *   session-peer drop ENDPOINT FILE JOB...   takes the first batch, writes its
 *                                            ticket, seq and a digest of its
 *                                            points to FILE, exits unanswered
 *   session-peer resume ENDPOINT FILE JOB... resumes FILE's session: checks
 *                                            that the batch served is the one
 *                                            dropped, finishes it
 *   session-peer steal ENDPOINT FILE         resume with FILE's ticket: prints
 *                                            the code and the message
 *   session-peer hostile ENDPOINT            NaN, Inf and 1e308 as values
 *   session-peer part ENDPOINT K/P JOB...    a part session (protocol version
 *                                            6): its sums must be libqmc's
 *                                            in-process part's, bit for bit;
 *                                            a refused open prints its code
 *                                            and message (exit 0)
 *   session-peer partdrop ENDPOINT FILE K/P JOB...   the same, but exits after
 *                                            its last batch, before the sums,
 *                                            its ticket in FILE
 *   session-peer partresume ENDPOINT FILE K/P JOB... resumes it: done, and
 *                                            the sums are the in-process part's
 *
 * JOB is `qmc integrate`'s: --integrand NAME --dims D --method M [--n N]
 * [--reps R] [--seed S] [--seq K] [--scramble S] [--split-net] [--tol-abs
 * E] [--tol-rel E] [--max-evals N] [--max-batch N]; the spec is built as
 * the CLI builds it (client/cli/integrate_run.c, cmd_integrate.c).  A
 * result is printed as one JSON object with the fields `qmc integrate
 * --json` prints for them (numbers with every bit, %.17g), so the test
 * compares the two with Python's json.  Exit 0, or 1 with one line on
 * stderr.
 */
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "qmc/client.h"
#include "qmc/job.h"

__attribute__((format(printf, 1, 2))) static int fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "session-peer: ");
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return 1;
}

typedef struct job_args {
    qmc_job_spec js;
    uint64_t max_batch;
    qmc_job *job;
    const qmc_integrand *f;
} job_args;

/* `qmc integrate`'s options into a job and the integrate spec the CLI
 * would send (cli_integrate_spec, cli_integrate_defaults). */
static int parse_job(int argc, char **argv, job_args *j)
{
    memset(j, 0, sizeof *j);
    qmc_job_spec *s = &j->js;
    qmc_job_spec_init(s);
    qmc_integrate_spec *in = &s->integrate;
    qmc_sampling_spec_init(&in->sampling, QMC_SAMPLER_MC);
    const char *method = "auto";
    int have_n = 0, have_reps = 0, have_scramble = 0;
    for (int i = 0; i + 1 < argc; i += 2) {
        const char *k = argv[i], *v = argv[i + 1];
        if (strcmp(k, "--integrand") == 0)
            snprintf(s->integrand, sizeof s->integrand, "%s", v);
        else if (strcmp(k, "--dims") == 0)
            s->dims = (uint32_t)strtoul(v, NULL, 10);
        else if (strcmp(k, "--method") == 0)
            method = v;
        else if (strcmp(k, "--n") == 0)
            in->sampling.n = strtoull(v, NULL, 10), have_n = 1;
        else if (strcmp(k, "--reps") == 0)
            in->sampling.reps = (uint32_t)strtoul(v, NULL, 10), have_reps = 1;
        else if (strcmp(k, "--seed") == 0)
            in->sampling.seed = strtoull(v, NULL, 10);
        else if (strcmp(k, "--seq") == 0) {
            if (qmc_seq_kind_parse(v, &in->sampling.seq) != 0)
                return fail("bad --seq %s%s", v, "");
        } else if (strcmp(k, "--scramble") == 0) {
            if (qmc_scramble_parse(v, &in->sampling.scramble) != 0)
                return fail("bad --scramble %s%s", v, "");
            have_scramble = 1;
        } else if (strcmp(k, "--tol-abs") == 0)
            in->tol_abs = strtod(v, NULL);
        else if (strcmp(k, "--tol-rel") == 0)
            in->tol_rel = strtod(v, NULL);
        else if (strcmp(k, "--max-evals") == 0)
            in->max_evals = strtoull(v, NULL, 10);
        else if (strcmp(k, "--max-batch") == 0)
            j->max_batch = strtoull(v, NULL, 10);
        else if (strcmp(k, "--split-net") == 0) {
            in->sampling.split_net = 1;
            i--; /* no value */
        } else
            return fail("unknown option %s%s", k, "");
    }
    if (qmc_method_parse(method, &in->method) != 0)
        return fail("unknown method %s%s", method, "");
    qmc_sampler smp;
    if (qmc_sampler_parse(method, &smp) == 0) {
        qmc_sampling_spec d;
        qmc_sampling_spec_init(&d, smp);
        in->sampling.sampler = smp;
        if (!have_scramble)
            in->sampling.scramble = d.scramble;
        if (!have_reps)
            in->sampling.reps = d.reps;
        if (smp == QMC_SAMPLER_STRATIFIED && !have_n) {
            uint64_t best = 1;
            for (uint64_t k = 2;; k++) {
                uint64_t q = 1;
                for (uint32_t d2 = 0; d2 < s->dims && q <= in->sampling.n; d2++)
                    q *= k;
                if (q > in->sampling.n)
                    break;
                best = q;
            }
            in->sampling.n = best;
        }
    }
    in->n_given = have_n;
    in->n_axis = have_n ? (uint32_t)in->sampling.n : 0;
    char why[256];
    if (qmc_job_new(s, &j->job, why, sizeof why) != 0)
        return fail("%s%s", why, "");
    j->f = qmc_job_integrand(j->job);
    return 0;
}

/* The session spec of the job: the integrate spec and what the built-in
 * integrand declares (its dims, smoothness, exact value). */
static void session_spec(const job_args *j, qmc_session_spec *ss)
{
    qmc_session_spec_init(ss);
    ss->integrate = j->js.integrate;
    ss->dims = j->f->dims;
    ss->smoothness = j->f->smoothness;
    ss->has_exact = j->f->has_exact;
    ss->exact = j->f->exact;
    ss->max_batch = j->max_batch;
}

static int eval_batch(void *ctx, const double *points, size_t count, uint32_t dims,
                      double *values)
{
    const qmc_integrand *f = ctx;
    f->eval(f->ctx, points, count, dims, values);
    return 0;
}

/* A number as `qmc integrate --json` prints it: every bit, NaN as null. */
static void num(const char *key, double v)
{
    if (v != v)
        printf("\"%s\":null,", key);
    else
        printf("\"%s\":%.17g,", key, v);
}

static void print_result(const qmc_client_result *r, unsigned long long batches)
{
    const qmc_result *x = &r->res;
    const double nan = 0.0 / 0.0;
    printf("{\"method_used\":\"%s\",\"detail\":\"%s\",", qmc_method_name(r->method_used),
           r->detail);
    if (r->auto_reason[0])
        printf("\"auto_reason\":\"%s\",", r->auto_reason);
    num("estimate", x->estimate);
    num("stderr", x->error_kind == QMC_ERROR_STDERR ? x->error : nan);
    num("error_estimate", x->error_kind == QMC_ERROR_ESTIMATE ? x->error : nan);
    num("ci_low", x->error_kind == QMC_ERROR_NONE ? nan : x->ci_low);
    num("ci_high", x->error_kind == QMC_ERROR_NONE ? nan : x->ci_high);
    printf("\"n\":%llu,\"evals\":%llu,\"dims\":%u,\"nonfinite\":%llu,\"batches\":%llu,"
           "\"flags\":[",
           (unsigned long long)x->n, (unsigned long long)x->evals, x->dims,
           (unsigned long long)x->nonfinite, batches);
    int first = 1;
    for (uint32_t bit = 1; bit; bit <<= 1)
        if (x->flags & bit) {
            printf("%s\"%s\"", first ? "" : ",", qmc_flag_key(bit));
            first = 0;
        }
    printf("]}\n");
}

static int connect_to(const char *endpoint, qmc_client **c)
{
    if (qmc_client_connect(endpoint, 60000, c) != 0) {
        fail("%s: %s", endpoint, qmc_client_last_error(*c));
        qmc_client_close(*c);
        return 1;
    }
    return 0;
}

/* FNV-1a over the batch's bytes: enough to tell one batch from another. */
static uint64_t digest(const double *p, size_t n)
{
    uint64_t h = 1469598103934665603ull;
    const unsigned char *b = (const unsigned char *)p;
    for (size_t i = 0; i < n * sizeof *p; i++)
        h = (h ^ b[i]) * 1099511628211ull;
    return h;
}

/* next/values/tell to the end. */
static int loop(qmc_client *c, qmc_client_session *s, const qmc_integrand *f)
{
    for (;;) {
        qmc_session_batch b;
        if (qmc_client_session_next(s, &b) != 0)
            return fail("next: %s%s", qmc_client_last_error(c), "");
        if (b.count == 0)
            return 0;
        double *v = qmc_client_session_values(s);
        f->eval(f->ctx, b.points, b.count, b.dims, v);
        if (qmc_client_session_tell(s, b.seq, v, b.count) != 0)
            return fail("tell: %s%s", qmc_client_last_error(c), "");
    }
}

static int finish(qmc_client *c, qmc_client_session *s)
{
    qmc_client_result r;
    qmc_session_report rep;
    qmc_client_session_report(s, &rep);
    if (qmc_client_session_result(s, &r) != 0)
        return fail("result: %s%s", qmc_client_last_error(c), "");
    print_result(&r, (unsigned long long)rep.batches);
    return 0;
}

static int cmd_run(const char *endpoint, job_args *j)
{
    qmc_client *c;
    if (connect_to(endpoint, &c))
        return 1;
    qmc_session_spec ss;
    session_spec(j, &ss);
    qmc_client_result r;
    int rc = 0;
    if (qmc_client_session_run(c, &ss, eval_batch, (void *)j->f, &r) != 0)
        rc = fail("run: %s%s", qmc_client_last_error(c), "");
    else
        print_result(&r, 0);
    qmc_client_close(c);
    return rc;
}

static int cmd_asktell(const char *endpoint, job_args *j)
{
    qmc_client *c;
    if (connect_to(endpoint, &c))
        return 1;
    qmc_session_spec ss;
    session_spec(j, &ss);
    qmc_client_session *s;
    int rc;
    if (qmc_client_session_open(c, &ss, &s) != 0) {
        rc = fail("open: %s%s", qmc_client_last_error(c), "");
    } else {
        rc = loop(c, s, j->f);
        if (!rc)
            rc = finish(c, s);
        qmc_client_session_free(s);
    }
    qmc_client_close(c);
    return rc;
}

/* FILE: the session's id and token, the batch dropped (seq, count and a
 * digest of its points), as read_ticket reads them. */
static int write_ticket(const char *file, const qmc_client_session_ticket *t,
                        unsigned long long seq, size_t count, unsigned long long dig)
{
    FILE *out = fopen(file, "w");
    if (!out)
        return fail("cannot write %s%s", file, "");
    fprintf(out, "%llu ", (unsigned long long)t->session_id);
    for (size_t i = 0; i < sizeof t->token; i++)
        fprintf(out, "%02x", t->token[i]);
    fprintf(out, " %llu %zu %016llx\n", seq, count, dig);
    return fclose(out) == 0 ? 0 : fail("cannot write %s%s", file, "");
}

static int cmd_drop(const char *endpoint, const char *file, job_args *j)
{
    qmc_client *c;
    if (connect_to(endpoint, &c))
        return 1;
    qmc_session_spec ss;
    session_spec(j, &ss);
    qmc_client_session *s;
    qmc_session_batch b;
    if (qmc_client_session_open(c, &ss, &s) != 0 || qmc_client_session_next(s, &b) != 0 ||
        b.count == 0)
        return fail("drop: %s%s", qmc_client_last_error(c), "");
    /* Answer the first batch, so that the one dropped is not batch 0. */
    double *v = qmc_client_session_values(s);
    j->f->eval(j->f->ctx, b.points, b.count, b.dims, v);
    if (qmc_client_session_tell(s, b.seq, v, b.count) != 0 ||
        qmc_client_session_next(s, &b) != 0 || b.count == 0)
        return fail("drop: %s%s", qmc_client_last_error(c), "");
    qmc_client_session_ticket t;
    qmc_client_session_ticket_get(s, &t);
    if (write_ticket(file, &t, b.seq, b.count, digest(b.points, b.count * b.dims)))
        return 1;
    printf("dropped session %llu at batch %llu (%zu points)\n",
           (unsigned long long)t.session_id, (unsigned long long)b.seq, b.count);
    fflush(stdout);
    _exit(0); /* the connection drops with the process: no close, no tell */
}

static int read_ticket(const char *file, qmc_client_session_ticket *t, unsigned long long *seq,
                       size_t *count, unsigned long long *dig)
{
    FILE *in = fopen(file, "r");
    char hex[2 * QMC_PROTO_SESSION_TOKEN_BYTES + 1];
    unsigned long long id = 0;
    int ok = in && fscanf(in, "%llu %64s %llu %zu %llx", &id, hex, seq, count, dig) == 5;
    if (in)
        fclose(in);
    if (!ok || strlen(hex) != sizeof hex - 1)
        return fail("cannot read a ticket from %s%s", file, "");
    memset(t, 0, sizeof *t);
    t->session_id = id;
    for (size_t i = 0; i < sizeof t->token; i++) {
        unsigned x;
        if (sscanf(hex + 2 * i, "%2x", &x) != 1)
            return fail("bad token in %s%s", file, "");
        t->token[i] = (uint8_t)x;
    }
    return 0;
}

static int cmd_resume(const char *endpoint, const char *file, job_args *j)
{
    qmc_client_session_ticket t;
    unsigned long long seq, dig;
    size_t count;
    if (read_ticket(file, &t, &seq, &count, &dig))
        return 1;
    qmc_client *c;
    if (connect_to(endpoint, &c))
        return 1;
    qmc_client_session *s;
    if (qmc_client_session_resume(c, &t, &s) != 0)
        return fail("resume: %s%s", qmc_client_last_error(c), "");
    qmc_session_batch b;
    if (qmc_client_session_next(s, &b) != 0)
        return fail("next: %s%s", qmc_client_last_error(c), "");
    const int same = b.seq == seq && b.count == count &&
                     digest(b.points, b.count * b.dims) == dig;
    printf("served again: %s (batch %llu of %zu points; dropped batch %llu of %zu)\n",
           same ? "yes" : "no", (unsigned long long)b.seq, b.count, seq, count);
    int rc = loop(c, s, j->f);
    if (!rc)
        rc = finish(c, s);
    qmc_client_session_free(s);
    qmc_client_close(c);
    return rc || !same;
}

static int cmd_steal(const char *endpoint, const char *file)
{
    qmc_client_session_ticket t;
    unsigned long long seq, dig;
    size_t count;
    if (read_ticket(file, &t, &seq, &count, &dig))
        return 1;
    qmc_client *c;
    if (connect_to(endpoint, &c))
        return 1;
    qmc_client_session *s = NULL;
    int r = qmc_client_session_resume(c, &t, &s);
    printf("resume: %d %s\n", r, qmc_client_last_error(c));
    qmc_client_session_free(s);
    qmc_client_close(c);
    return 0;
}

/* The session spec of part K/P of the job. */
static int part_spec(const job_args *j, const char *kp, qmc_session_spec *ss)
{
    session_spec(j, ss);
    char tail;
    if (sscanf(kp, "%u/%u%c", &ss->part_k, &ss->part_p, &tail) != 2)
        return fail("want K/P, not %s%s", kp, "");
    return 0;
}

/* A part's answer through the daemon against libqmc's in-process one for
 * the same spec and f: fingerprint, range, sampling spec, sums, bit for
 * bit.  0 (and a line saying so) or 1. */
static int same_as_here(const job_args *j, const qmc_session_spec *ss, const char *kp,
                        const qmc_session_part_sums *wire)
{
    static double v[1 << 16];
    qmc_session *ls = NULL;
    qmc_session_part_sums here;
    char why[256] = "";
    int rc = 0;
    if (qmc_session_new(ss, &ls, why, sizeof why) != 0)
        return fail("in-process: %s%s", why, "");
    for (;;) {
        qmc_session_batch b;
        if (qmc_session_ask(ls, &b) != 0 || b.count == 0)
            break;
        if (b.count > sizeof v / sizeof v[0]) {
            rc = fail("a batch of %zu points%s", b.count, "");
            break;
        }
        j->f->eval(j->f->ctx, b.points, b.count, b.dims, v);
        if (qmc_session_tell(ls, b.seq, v, b.count, why, sizeof why) != 0) {
            rc = fail("in-process tell: %s%s", why, "");
            break;
        }
    }
    if (rc == 0 && qmc_session_part(ls, &here) != 0)
        rc = fail("in-process part failed%s%s", "", "");
    if (rc == 0 &&
        (wire->fingerprint != here.fingerprint || wire->blocks != here.blocks ||
         wire->first != here.first || wire->count != here.count ||
         memcmp(&wire->sampling, &here.sampling, sizeof here.sampling) != 0 ||
         (here.count && memcmp(wire->sums, here.sums, here.count * sizeof *here.sums) != 0)))
        rc = fail("part %s through the daemon differs from in-process%s", kp, "");
    if (rc == 0)
        printf("part %s: blocks %llu, first %llu, count %llu: the in-process sums\n", kp,
               (unsigned long long)wire->blocks, (unsigned long long)wire->first,
               (unsigned long long)wire->count);
    qmc_session_free(ls);
    return rc;
}

/* A part session's answer, here and through the daemon: the same.  With
 * drop_file: answers every batch, then writes the ticket there and exits
 * before reading the sums (the connection drops with the process, the
 * daemon parks the session with its sums unsent). */
static int cmd_part(const char *endpoint, const char *kp, const char *drop_file, job_args *j)
{
    qmc_session_spec ss;
    if (part_spec(j, kp, &ss))
        return 1;
    qmc_client *c;
    if (connect_to(endpoint, &c))
        return 1;
    qmc_client_session *s = NULL;
    int r = qmc_client_session_open(c, &ss, &s);
    if (r != 0) {
        printf("refused %s: %s\n", qmc_err_name(r), qmc_client_last_error(c));
        qmc_client_close(c);
        return 0;
    }
    int rc = 0;
    for (;;) {
        qmc_session_batch b;
        qmc_session_report rep;
        if (qmc_client_session_next(s, &b) != 0) {
            rc = fail("next: %s%s", qmc_client_last_error(c), "");
            break;
        }
        if (b.count == 0)
            break;
        double *v = qmc_client_session_values(s);
        j->f->eval(j->f->ctx, b.points, b.count, b.dims, v);
        if (qmc_client_session_tell(s, b.seq, v, b.count) != 0) {
            rc = fail("tell: %s%s", qmc_client_last_error(c), "");
            break;
        }
        qmc_client_session_report(s, &rep);
        if (drop_file && rep.end != QMC_SESSION_RUNNING) {
            qmc_client_session_ticket t;
            qmc_client_session_ticket_get(s, &t);
            if (write_ticket(drop_file, &t, 0, 0, 0)) /* no batch waits */
                return 1;
            printf("dropped part %s after its last batch\n", kp);
            fflush(stdout);
            _exit(0);
        }
    }
    qmc_session_part_sums wire;
    if (rc == 0 && (r = qmc_client_session_part(s, &wire)) != 0)
        rc = fail("part: %s %s", qmc_err_name(r), qmc_client_last_error(c));
    if (rc == 0)
        rc = same_as_here(j, &ss, kp, &wire);
    qmc_client_session_free(s);
    qmc_client_close(c);
    return rc;
}

/* Resumes a part dropped by cmd_part after its last batch: the session
 * is done, and its sums come whole on the new connection. */
static int cmd_part_resume(const char *endpoint, const char *file, const char *kp,
                           job_args *j)
{
    qmc_session_spec ss;
    qmc_client_session_ticket t;
    unsigned long long seq, dig;
    size_t count;
    if (part_spec(j, kp, &ss) || read_ticket(file, &t, &seq, &count, &dig))
        return 1;
    qmc_client *c;
    if (connect_to(endpoint, &c))
        return 1;
    qmc_client_session *s;
    qmc_session_batch b;
    qmc_session_part_sums wire;
    int rc = 0, r;
    if (qmc_client_session_resume(c, &t, &s) != 0)
        return fail("resume: %s%s", qmc_client_last_error(c), "");
    if (qmc_client_session_next(s, &b) != 0 || b.count != 0)
        rc = fail("a resumed finished part asked for more: %s%s", qmc_client_last_error(c), "");
    else if ((r = qmc_client_session_part(s, &wire)) != 0)
        rc = fail("part: %s %s", qmc_err_name(r), qmc_client_last_error(c));
    if (rc == 0)
        rc = same_as_here(j, &ss, kp, &wire);
    qmc_client_session_free(s);
    qmc_client_close(c);
    return rc;
}

/* Values a caller may send that no integrand should: NaN, infinities, a
 * finite 1e308 whose square overflows.  qmcd counts and flags them. */
static int cmd_hostile(const char *endpoint)
{
    qmc_client *c;
    if (connect_to(endpoint, &c))
        return 1;
    qmc_session_spec ss;
    qmc_session_spec_init(&ss);
    ss.dims = 2;
    ss.integrate.method = QMC_METHOD_RQMC;
    qmc_sampling_spec_init(&ss.integrate.sampling, QMC_SAMPLER_RQMC);
    ss.integrate.sampling.reps = 8;
    ss.integrate.sampling.n = 1024;
    ss.integrate.n_given = 1;
    qmc_client_session *s;
    if (qmc_client_session_open(c, &ss, &s) != 0)
        return fail("open: %s%s", qmc_client_last_error(c), "");
    uint64_t sent_nonfinite = 0;
    for (;;) {
        qmc_session_batch b;
        if (qmc_client_session_next(s, &b) != 0)
            return fail("next: %s%s", qmc_client_last_error(c), "");
        if (b.count == 0)
            break;
        double *v = qmc_client_session_values(s);
        for (size_t i = 0; i < b.count; i++)
            v[i] = 1.0;
        if (b.seq == 0 && b.count >= 3) {
            v[0] = 0.0 / 0.0;
            v[1] = 1.0 / 0.0;
            v[2] = 1e308;
            sent_nonfinite += 2;
        }
        if (qmc_client_session_tell(s, b.seq, v, b.count) != 0)
            return fail("tell: %s%s", qmc_client_last_error(c), "");
    }
    qmc_session_report rep;
    qmc_client_session_report(s, &rep);
    qmc_client_result r;
    int err = qmc_client_session_result(s, &r);
    printf("sent nonfinite %llu; report nonfinite %llu end %s; result err %d nonfinite %llu "
           "flags",
           (unsigned long long)sent_nonfinite, (unsigned long long)rep.nonfinite,
           qmc_session_end_key(rep.end), err, (unsigned long long)r.res.nonfinite);
    for (uint32_t bit = 1; bit; bit <<= 1)
        if (r.res.flags & bit)
            printf(" %s", qmc_flag_key(bit));
    printf("\n");
    qmc_client_session_free(s);
    qmc_client_close(c);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 3)
        return fail("usage: session-peer run|asktell|drop|resume|steal|hostile|part|partdrop|"
                    "partresume ENDPOINT ...%s%s",
                    "", "");
    const char *cmd = argv[1], *endpoint = argv[2];
    if (strcmp(cmd, "hostile") == 0)
        return cmd_hostile(endpoint);
    if (strcmp(cmd, "steal") == 0)
        return argc == 4 ? cmd_steal(endpoint, argv[3]) : fail("steal ENDPOINT FILE%s%s", "", "");
    const int parts2 = strcmp(cmd, "partdrop") == 0 || strcmp(cmd, "partresume") == 0;
    int file_arg = strcmp(cmd, "drop") == 0 || strcmp(cmd, "resume") == 0 ||
                   strcmp(cmd, "part") == 0; /* part's K/P stands where the file would */
    file_arg += 2 * parts2;                  /* FILE K/P */
    if (argc < 3 + file_arg)
        return fail("%s needs a file%s", cmd, "");
    job_args j;
    if (parse_job(argc - 3 - file_arg, argv + 3 + file_arg, &j))
        return 1;
    int rc;
    if (strcmp(cmd, "run") == 0)
        rc = cmd_run(endpoint, &j);
    else if (strcmp(cmd, "asktell") == 0)
        rc = cmd_asktell(endpoint, &j);
    else if (strcmp(cmd, "drop") == 0)
        rc = cmd_drop(endpoint, argv[3], &j);
    else if (strcmp(cmd, "resume") == 0)
        rc = cmd_resume(endpoint, argv[3], &j);
    else if (strcmp(cmd, "part") == 0)
        rc = cmd_part(endpoint, argv[3], NULL, &j);
    else if (strcmp(cmd, "partdrop") == 0)
        rc = cmd_part(endpoint, argv[4], argv[3], &j);
    else if (strcmp(cmd, "partresume") == 0)
        rc = cmd_part_resume(endpoint, argv[3], argv[4], &j);
    else
        rc = fail("unknown command %s%s", cmd, "");
    qmc_job_free(j.job);
    return rc;
}
