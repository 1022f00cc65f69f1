/*
 * result_msg.c - an integration report as a result message's body (see
 * result_msg.h).  Must not: send, count, or copy the texts (the message
 * only points at them).
 */
#include "result_msg.h"

#include <string.h>

void qmcd_result_of(qmc_msg_job_result *res, uint64_t id, const qmc_integrate_report *rep)
{
    res->job_id = id;
    res->res = rep->res;
    res->cv = rep->cv;
    res->method_used = rep->method_used;
    res->sampling = rep->sampling;
    res->detail.ptr = rep->detail;
    res->detail.len = (uint32_t)strnlen(rep->detail, sizeof rep->detail);
    res->auto_reason.ptr = rep->auto_reason;
    res->auto_reason.len = (uint32_t)strnlen(rep->auto_reason, sizeof rep->auto_reason);
}
