/*
 * fiber.c - a function on its own stack that yields and is resumed (see
 * fiber.h): getcontext/makecontext to start it, swapcontext both ways.
 *
 * Must not: allocate anything but the fiber and its stack, or yield from
 * outside the fiber.
 */
/* makecontext and swapcontext are XSI (dropped from POSIX 2008, still in
 * glibc): the build's _POSIX_C_SOURCE alone hides nothing of ucontext.h,
 * which glibc declares unconditionally. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <ucontext.h>

#include "fiber.h"

#ifdef QMC__FIBER_SANITIZED
#include <sanitizer/common_interface_defs.h>
#endif

/* The paint pattern: a byte the stack is unlikely to hold in long runs. */
enum { PAINT = 0xa5 };

struct qmc__fiber {
    ucontext_t caller;     /* where resume was called, saved by the switch in */
    ucontext_t self;       /* the fiber, saved by yield */
    unsigned char *stack;
    size_t stack_bytes;
    void (*entry)(void *arg);
    void *arg;
    int started, finished, painted;
    /* ASan: the fake stacks saved across a switch, and the stack of the
     * thread that last resumed the fiber (what a yield switches to). */
    void *fake_caller, *fake_self;
    const void *caller_bottom;
    size_t caller_size;
};

#ifdef QMC__FIBER_SANITIZED
static void switch_start(void **fake_save, const void *bottom, size_t size)
{
    __sanitizer_start_switch_fiber(fake_save, bottom, size);
}

static void switch_finish(void *fake_save, const void **old_bottom, size_t *old_size)
{
    __sanitizer_finish_switch_fiber(fake_save, old_bottom, old_size);
}
#else
static void switch_start(void **fake_save, const void *bottom, size_t size)
{
    (void)fake_save;
    (void)bottom;
    (void)size;
}

static void switch_finish(void *fake_save, const void **old_bottom, size_t *old_size)
{
    (void)fake_save;
    (void)old_bottom;
    (void)old_size;
}
#endif

/* makecontext passes int arguments only: the fiber's address travels as
 * two 32-bit halves. */
static void trampoline(unsigned lo, unsigned hi)
{
    qmc__fiber *f = (qmc__fiber *)(uintptr_t)(((uint64_t)hi << 32) | lo);
    switch_finish(NULL, &f->caller_bottom, &f->caller_size);
    f->entry(f->arg);
    f->finished = 1;
    /* NULL: this stack is done, ASan may drop its fake frames. */
    switch_start(NULL, f->caller_bottom, f->caller_size);
    setcontext(&f->caller);
}

qmc__fiber *qmc__fiber_new(size_t stack_bytes, void (*entry)(void *arg), void *arg, int paint)
{
    qmc__fiber *f = calloc(1, sizeof *f);
    if (!f)
        return NULL;
    f->stack = malloc(stack_bytes); /* malloc's alignment suffices: makecontext aligns sp */
    if (!f->stack) {
        free(f);
        return NULL;
    }
    f->stack_bytes = stack_bytes;
    f->entry = entry;
    f->arg = arg;
    if (paint) {
        memset(f->stack, PAINT, stack_bytes);
        f->painted = 1;
    }
    return f;
}

size_t qmc__fiber_bytes(size_t stack_bytes)
{
    return sizeof(qmc__fiber) + stack_bytes;
}

void qmc__fiber_free(qmc__fiber *f)
{
    if (!f)
        return;
    free(f->stack);
    free(f);
}

int qmc__fiber_resume(qmc__fiber *f)
{
    if (f->finished)
        return 0;
    if (!f->started) {
        f->started = 1;
        getcontext(&f->self);
        f->self.uc_stack.ss_sp = f->stack;
        f->self.uc_stack.ss_size = f->stack_bytes;
        f->self.uc_link = NULL; /* trampoline never returns: it switches back itself */
        const uint64_t p = (uint64_t)(uintptr_t)f;
        makecontext(&f->self, (void (*)(void))trampoline, 2, (unsigned)(p & 0xffffffffu),
                    (unsigned)(p >> 32));
    }
    switch_start(&f->fake_caller, f->stack, f->stack_bytes);
    swapcontext(&f->caller, &f->self);
    switch_finish(f->fake_caller, NULL, NULL);
    return !f->finished;
}

void qmc__fiber_yield(qmc__fiber *f)
{
    switch_start(&f->fake_self, f->caller_bottom, f->caller_size);
    swapcontext(&f->self, &f->caller);
    /* Resumed, perhaps by another thread: its stack is the one to return
     * to next time. */
    switch_finish(f->fake_self, &f->caller_bottom, &f->caller_size);
}

size_t qmc__fiber_stack_used(const qmc__fiber *f)
{
    if (!f->painted)
        return 0;
    /* The stack grows down from stack + stack_bytes: the lowest byte that
     * lost the pattern marks the deepest frame. */
    size_t i = 0;
    while (i < f->stack_bytes && f->stack[i] == PAINT)
        i++;
    return f->stack_bytes - i;
}
