/*
 * gnuplot.c - runs gnuplot on a generated script (see gnuplot.h).
 */
#include <errno.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "cli.h"
#include "gnuplot.h"

void cli_gnuplot_quote(FILE *script, const char *s)
{
    fputc('\'', script);
    for (; *s; s++) {
        if (*s == '\'')
            fputc('\'', script);
        fputc(*s, script);
    }
    fputc('\'', script);
}

void cli_gnuplot_terminal(FILE *script, const char *kind, int width, int height,
                          const char *output_path)
{
    if (strcmp(kind, "svg") == 0)
        fprintf(script, "set terminal svg size %d,%d noenhanced font 'sans,11' background '#ffffff'\n",
                width, height);
    else
        fprintf(script, "set terminal pngcairo size %d,%d noenhanced font ',9'\n", width, height);
    fputs("set output ", script);
    cli_gnuplot_quote(script, output_path);
    fputc('\n', script);
}

int cli_gnuplot_run(const char *script_path)
{
    int fd[2];
    if (pipe(fd) != 0)
        return cli_error("gnuplot: pipe: %s", strerror(errno)), -1;
    pid_t pid = fork();
    if (pid < 0) {
        close(fd[0]), close(fd[1]);
        return cli_error("gnuplot: fork: %s", strerror(errno)), -1;
    }
    if (pid == 0) {
        dup2(fd[1], 2);
        dup2(fd[1], 1);
        close(fd[0]), close(fd[1]);
        execlp("gnuplot", "gnuplot", script_path, (char *)NULL);
        fprintf(stderr, "cannot run gnuplot: %s (install gnuplot-nox)\n", strerror(errno));
        _exit(127);
    }
    close(fd[1]);
    /* gnuplot echoes the offending command, a caret, then the reason on
     * its last line: keep the tail of what it says */
    char msg[8192];
    size_t got = 0;
    ssize_t r;
    for (;;) {
        if (got == sizeof msg - 1) { /* keep the second half */
            memmove(msg, msg + sizeof msg / 2, got - sizeof msg / 2);
            got -= sizeof msg / 2;
        }
        r = read(fd[0], msg + got, sizeof msg - 1 - got);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0)
            break;
        got += (size_t)r;
    }
    close(fd[0]);
    msg[got] = '\0';
    int status;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR)
        ;
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0)
        return 0;
    while (got > 0 && (msg[got - 1] == '\n' || msg[got - 1] == ' '))
        msg[--got] = '\0';
    char *line = strrchr(msg, '\n');
    line = line ? line + 1 : msg;
    if (strlen(line) > 200)
        line[200] = '\0';
    return cli_error("gnuplot failed on %s: %s", script_path, line[0] ? line : "no message"), -1;
}
