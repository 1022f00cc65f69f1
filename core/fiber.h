/*
 * fiber.h - a function run on its own stack that can stop in the middle
 * and be continued later, perhaps by another thread (private to core/).
 *
 * An integration session (session.c) runs an unchanged integrator inside
 * one: when the integrator calls its integrand, the fiber yields back to
 * whoever resumed it, with the batch of points; when the values arrive the
 * session resumes it and the integrand call returns.  While it waits, a
 * fiber is only memory (its stack and saved registers): it holds no thread.
 *
 * Built on POSIX ucontext (getcontext, makecontext, swapcontext).  Must
 * not: run anything by itself, keep globals, or be resumed by two threads
 * at once (the caller serialises; a fiber is not thread-safe).
 *
 * Resuming on another thread.  The fiber's own frames never learn which
 * thread runs them, and glibc's swapcontext on x86-64 and aarch64 does not
 * save or restore the thread pointer: after a resume on thread B the
 * fiber's code reads B's thread-locals (errno, ASan's per-thread state).
 * That is correct as long as no code on the fiber caches the address of a
 * thread-local across a yield; the integrators core runs on it take no
 * thread-local's address at all (they do not touch errno; libm computes
 * errno's address afresh on each call).  swapcontext also saves and
 * restores the signal mask (one rt_sigprocmask system call each way):
 * while on the fiber, a thread runs with the mask the fiber last saved -
 * the mask of the thread that last resumed it - and gets its own back when
 * the fiber yields.  Threads that share one mask (qmcd's workers) see no
 * difference.
 *
 * Under AddressSanitizer each switch is announced with
 * __sanitizer_start_switch_fiber / __sanitizer_finish_switch_fiber, so
 * ASan knows which stack is live (and where the resuming thread's stack
 * is, which may differ from one resume to the next).
 */
#ifndef QMC_FIBER_H
#define QMC_FIBER_H

#include <stddef.h>

typedef struct qmc__fiber qmc__fiber;

/* Bytes of fiber stack a session gets.  test_session measures the deepest
 * any method reaches: 37 KiB plain (auto's VEGAS-mapped integrand keeps
 * 32 KiB of points and Jacobians on the stack; no integrator recurses or
 * sizes a frame by the dimension), 48 KiB under ASan+UBSan.  Plain builds
 * get 128 KiB; sanitized builds 4x that, as redzones widen every frame. */
#if defined(__SANITIZE_ADDRESS__)
#define QMC__FIBER_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define QMC__FIBER_SANITIZED 1
#endif
#endif
#ifdef QMC__FIBER_SANITIZED
#define QMC__FIBER_STACK_BYTES (512u << 10)
#else
#define QMC__FIBER_STACK_BYTES (128u << 10)
#endif

/*
 * A fiber that will run entry(arg) on a stack of stack_bytes, once
 * resumed.  paint != 0 fills the stack with a pattern first so that
 * qmc__fiber_stack_used can measure its high-water mark (tests; it makes
 * every page of the stack resident).  Returns NULL when memory is short.
 */
qmc__fiber *qmc__fiber_new(size_t stack_bytes, void (*entry)(void *arg), void *arg, int paint);

/* The bytes qmc__fiber_new allocates for a stack of stack_bytes. */
size_t qmc__fiber_bytes(size_t stack_bytes);

/* Frees the fiber's stack and itself.  The fiber must not be suspended in
 * the middle of entry (it would leak what entry's frames own): finish it
 * first.  NULL is a no-op. */
void qmc__fiber_free(qmc__fiber *f);

/* From outside: runs the fiber until it yields or entry returns.  Returns
 * 1 while it is suspended in a yield, 0 once entry has returned (resuming
 * a finished fiber does nothing and returns 0). */
int qmc__fiber_resume(qmc__fiber *f);

/* From inside entry: back to the caller of qmc__fiber_resume; returns when
 * the fiber is resumed again (on whatever thread). */
void qmc__fiber_yield(qmc__fiber *f);

/* Bytes of the stack that were ever written, when painted (else 0). */
size_t qmc__fiber_stack_used(const qmc__fiber *f);

#endif
