/*
 * result_msg.h - an integration report as the body of a JOB_RESULT or a
 * SESSION_RESULT (PROTOCOL.md): both answers carry the same fields from
 * the same qmc_integrate_report, so they are filled in one place.
 */
#ifndef QMCD_RESULT_MSG_H
#define QMCD_RESULT_MSG_H

#include <stdint.h>

#include "qmc/integrate.h"
#include "qmc/proto.h"

/* Fills res's id and every field rep holds (result, control variate,
 * method used, sampling, detail and auto's reason); the caller adds
 * seconds and the reference.  The two texts point into rep, which must
 * outlive the send. */
void qmcd_result_of(qmc_msg_job_result *res, uint64_t id, const qmc_integrate_report *rep);

#endif
