/*
 * command_proc.c - the --command child process (see command_proc.h).
 * Must not: leave a child running or unreaped on any path qmc can take
 * (error, success, a fatal signal), let SIGPIPE kill qmc, or hand the
 * child our descriptors or our signal handlers.
 */
/* pipe2, O_CLOEXEC. */
#define _GNU_SOURCE
#include "command_proc.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#ifdef __linux__
#include <sys/prctl.h>
#endif

/* ---- the signal slot -------------------------------------------------------
 * The child's process group, for the handler: the one piece of state a
 * handler can reach.  0 when no child runs. */
static volatile sig_atomic_t child_pgid;
static const int fatal_signals[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};
#define N_FATAL (sizeof fatal_signals / sizeof fatal_signals[0])
static struct sigaction saved_fatal[N_FATAL], saved_pipe;
static int installed;

static void on_fatal(int sig)
{
    int saved_errno = errno;
    pid_t g = (pid_t)child_pgid;
    if (g > 0) {
        kill(-g, SIGKILL);
        /* Every member of the group that is our child: the shell, and
         * (we are their subreaper) what it started. */
        while (waitpid(-g, NULL, 0) >= 0 || errno == EINTR) {
        }
        child_pgid = 0;
    }
    for (size_t i = 0; i < N_FATAL; i++) {
        if (fatal_signals[i] != sig)
            continue;
        /* Hand on to what was there: outfile.c's handler removes its
         * temporary files and re-raises; else the default action. */
        sigaction(sig, &saved_fatal[i], NULL);
        if (saved_fatal[i].sa_handler != SIG_DFL && saved_fatal[i].sa_handler != SIG_IGN &&
            !(saved_fatal[i].sa_flags & SA_SIGINFO)) {
            saved_fatal[i].sa_handler(sig);
        } else {
            struct sigaction dfl;
            memset(&dfl, 0, sizeof dfl);
            dfl.sa_handler = SIG_DFL;
            sigemptyset(&dfl.sa_mask);
            sigaction(sig, &dfl, NULL);
            raise(sig); /* delivered with the default action when we return */
        }
    }
    errno = saved_errno;
}

static void install(void)
{
    if (installed)
        return;
    installed = 1;
    struct sigaction ign;
    memset(&ign, 0, sizeof ign);
    ign.sa_handler = SIG_IGN;
    sigemptyset(&ign.sa_mask);
    sigaction(SIGPIPE, &ign, &saved_pipe);
    for (size_t i = 0; i < N_FATAL; i++) {
        sigaction(fatal_signals[i], NULL, &saved_fatal[i]);
        /* A signal the caller ignores (nohup, a background job) stays so. */
        if (saved_fatal[i].sa_handler == SIG_IGN)
            continue;
        struct sigaction sa;
        memset(&sa, 0, sizeof sa);
        sa.sa_handler = on_fatal;
        sigemptyset(&sa.sa_mask);
        for (size_t k = 0; k < N_FATAL; k++)
            sigaddset(&sa.sa_mask, fatal_signals[k]);
        sigaction(fatal_signals[i], &sa, NULL);
    }
}

static void uninstall(void)
{
    if (!installed)
        return;
    installed = 0;
    for (size_t i = 0; i < N_FATAL; i++)
        sigaction(fatal_signals[i], &saved_fatal[i], NULL);
    sigaction(SIGPIPE, &saved_pipe, NULL);
}

static void block_fatal(sigset_t *old)
{
    sigset_t set;
    sigemptyset(&set);
    for (size_t i = 0; i < N_FATAL; i++)
        sigaddset(&set, fatal_signals[i]);
    sigprocmask(SIG_BLOCK, &set, old);
}

/* ---- the child ----------------------------------------------------------------- */

static void close_fd(int *fd)
{
    if (*fd >= 0)
        close(*fd);
    *fd = -1;
}

int cli_child_start(cli_child *c, const char *command, char *why, size_t why_bytes)
{
    memset(c, 0, sizeof *c);
    c->to_fd = c->from_fd = -1;
    int in[2], out[2];
    if (pipe2(in, O_CLOEXEC) != 0) {
        snprintf(why, why_bytes, "cannot make a pipe: %s", strerror(errno));
        return -1;
    }
    if (pipe2(out, O_CLOEXEC) != 0) {
        snprintf(why, why_bytes, "cannot make a pipe: %s", strerror(errno));
        close(in[0]), close(in[1]);
        return -1;
    }
    /* The fatal signals wait until the child is in the slot: a signal
     * between fork and then would otherwise leave it running. */
#ifdef PR_SET_CHILD_SUBREAPER
    /* The shell may fork PROGRAM rather than exec it (dash does): once the
     * shell is gone, PROGRAM is then our child too, so that we reap it
     * rather than leave a zombie to an init that may not. */
    prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0);
#endif
    sigset_t old;
    block_fatal(&old);
    install();
    pid_t pid = fork();
    if (pid == 0) {
        /* The child: its own group (so that one kill reaches whatever the
         * shell starts), the signal state qmc started with, the pipes on
         * 0 and 1 (dup2 clears close-on-exec there). */
        setpgid(0, 0);
        sigaction(SIGPIPE, &saved_pipe, NULL);
        for (size_t i = 0; i < N_FATAL; i++)
            sigaction(fatal_signals[i], &saved_fatal[i], NULL);
        sigprocmask(SIG_SETMASK, &old, NULL);
        if (dup2(in[0], 0) < 0 || dup2(out[1], 1) < 0)
            _exit(127);
        execl("/bin/sh", "sh", "-c", command, (char *)NULL);
        _exit(127);
    }
    int fork_errno = errno;
    close(in[0]);
    close(out[1]);
    if (pid < 0) {
        close(in[1]), close(out[0]);
        uninstall();
        sigprocmask(SIG_SETMASK, &old, NULL);
        snprintf(why, why_bytes, "cannot start a process: %s", strerror(fork_errno));
        return -1;
    }
    setpgid(pid, pid); /* also here: whichever runs first, the group exists */
    c->pid = pid;
    child_pgid = pid;
    sigprocmask(SIG_SETMASK, &old, NULL);
    c->to_fd = in[1];
    c->from_fd = out[0];
    fcntl(c->to_fd, F_SETFL, fcntl(c->to_fd, F_GETFL) | O_NONBLOCK);
    fcntl(c->from_fd, F_SETFL, fcntl(c->from_fd, F_GETFL) | O_NONBLOCK);
    return 0;
}

void cli_child_close_input(cli_child *c)
{
    close_fd(&c->to_fd);
}

/* Reaps what is left of the group: members that are our children (the
 * shell, and what it started once it is gone), killed already. */
static void reap_group(pid_t g)
{
    while (waitpid(-g, NULL, 0) >= 0 || errno == EINTR) {
    }
}

/* Reaps it if it has exited.  Its whole group is killed first, while the
 * zombie still holds the group's number (so the number cannot have passed
 * to anyone else): what the shell started must not outlive it. */
static int try_reap(cli_child *c)
{
    if (c->reaped)
        return 1;
    if (c->pid <= 0)
        return 0;
    siginfo_t info;
    memset(&info, 0, sizeof info);
    while (waitid(P_PID, (id_t)c->pid, &info, WEXITED | WNOHANG | WNOWAIT) < 0) {
        if (errno != EINTR)
            return 0;
    }
    if (info.si_pid != c->pid)
        return 0;
    kill(-c->pid, SIGKILL);
    int st;
    while (waitpid(c->pid, &st, 0) < 0) {
        if (errno != EINTR)
            return 0;
    }
    c->reaped = 1;
    c->status = st;
    reap_group(c->pid);
    child_pgid = 0;
    return 1;
}

int cli_child_wait(cli_child *c, int timeout_ms)
{
    /* No descriptor to poll for a child's exit in POSIX: look, then sleep
     * 1 ms, 2 ms, ... up to 50 ms between looks, until the time is up. */
    long waited_us = 0, step_us = 1000;
    while (!try_reap(c) && waited_us < (long)timeout_ms * 1000) {
        struct timespec ts = {0, step_us * 1000};
        nanosleep(&ts, NULL);
        waited_us += step_us;
        if (step_us < 50000)
            step_us *= 2;
    }
    return c->reaped;
}

void cli_child_stop(cli_child *c)
{
    if (c->pid > 0 && !try_reap(c)) {
        kill(-c->pid, SIGKILL);
        c->killed = 1;
        int st;
        pid_t r;
        while ((r = waitpid(c->pid, &st, 0)) < 0 && errno == EINTR) {
        }
        if (r == c->pid) {
            c->reaped = 1;
            c->status = st;
        }
        reap_group(c->pid);
    }
    if (c->pid > 0) {
        sigset_t old;
        block_fatal(&old);
        child_pgid = 0;
        uninstall();
        sigprocmask(SIG_SETMASK, &old, NULL);
        c->pid = 0; /* stopped: never signalled again (the number may be reused) */
    }
    close_fd(&c->to_fd);
    close_fd(&c->from_fd);
}

void cli_child_describe(const cli_child *c, char *buf, size_t cap)
{
    if (!c->reaped)
        snprintf(buf, cap, "is still running");
    else if (WIFEXITED(c->status) && WEXITSTATUS(c->status) == 127)
        snprintf(buf, cap, "exited with status 127 (the shell could not run it?)");
    else if (WIFEXITED(c->status))
        snprintf(buf, cap, "exited with status %d", WEXITSTATUS(c->status));
    else if (WIFSIGNALED(c->status))
        snprintf(buf, cap, "was killed by signal %d (%s)", WTERMSIG(c->status),
                 strsignal(WTERMSIG(c->status)));
    else
        snprintf(buf, cap, "ended (wait status %#x)", (unsigned)c->status);
}
