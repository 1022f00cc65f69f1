#!/usr/bin/python3
"""readme_tour.py - runs the tour in README.md and checks what it prints.

Usage: readme_tour.py README ROOT RUN

The convention (also written at the top of the tour in README.md):

  * The tour is everything between the line that starts with
    "<!-- tour:begin" (the HTML comment it opens runs to the first line
    that ends with "-->") and the line "<!-- tour:end -->".
  * Every ```sh block in it runs, in order, in ONE bash shell with
    `set -e -o pipefail`, so variables, `cd` and `export` carry from one
    block to the next as they do when a reader pastes them.  The shell
    starts in ROOT (a stand-in for the repository root: ROOT/build holds
    the qmc and qmcd under test) with stdin from /dev/null.
  * A ```text block that follows a ```sh block with only blank lines in
    between is the stdout that block must print, line for line.  In an
    expected line, `...` matches any text; a line that is only `...`
    matches any number of lines (none included).  stderr is not compared
    (it is shown when something fails).
  * Any other fenced block in the tour, or a ```text block that follows
    no ```sh block, is an error: nothing in the tour goes unchecked by
    accident.

It also checks that every relative Markdown link in README.md,
docs/DESIGN.md and docs/BENCHMARKS.md names a file that exists.

RUN is a directory for the generated script and each block's stdout and
stderr.  Prints one "ok ..." or "FAIL ..." line per check and a final
"N passed, M failed"; exits 1 if anything failed.  Stopping what the tour
leaves running is the caller's job (test_readme.sh).
"""
import difflib
import os
import re
import subprocess
import sys

BEGIN = "<!-- tour:begin"
END = "<!-- tour:end -->"
# A hang guard only (the tour takes seconds); never an assertion on time.
TIMEOUT_S = 600


class TourError(Exception):
    pass


def parse(path):
    """Returns [(readme_line, code, expected_lines_or_None, text_line)]."""
    lines = open(path, encoding="utf-8").read().split("\n")
    starts = [i for i, l in enumerate(lines) if l.startswith(BEGIN)]
    ends = [i for i, l in enumerate(lines) if l.strip() == END]
    if len(starts) != 1 or len(ends) != 1:
        raise TourError("%s: want exactly one %r and one %r line, found %d and %d"
                        % (path, BEGIN, END, len(starts), len(ends)))
    i = starts[0]
    while not lines[i].rstrip().endswith("-->"):
        i += 1
        if i >= ends[0]:
            raise TourError("%s:%d: the tour:begin comment is never closed"
                            % (path, starts[0] + 1))
    i += 1
    blocks = []
    last_kind = None      # "sh" / "text" / "prose": what came last
    while i < ends[0]:
        line = lines[i]
        if line.startswith("```"):
            lang = line[3:].strip()
            open_at = i
            body = []
            i += 1
            while i < ends[0] and not lines[i].startswith("```"):
                body.append(lines[i])
                i += 1
            if i >= ends[0]:
                raise TourError("%s:%d: fenced block never closed"
                                % (path, open_at + 1))
            if lines[i].strip() != "```":
                raise TourError("%s:%d: a fence closes with %r" % (path, i + 1, lines[i]))
            i += 1
            if lang == "sh":
                blocks.append([open_at + 2, "\n".join(body), None, None])
                last_kind = "sh"
            elif lang == "text":
                if last_kind != "sh":
                    raise TourError("%s:%d: a ```text block must follow a ```sh block "
                                    "(only blank lines between)" % (path, open_at + 1))
                blocks[-1][2] = body
                blocks[-1][3] = open_at + 2
                last_kind = "text"
            else:
                raise TourError("%s:%d: ```%s block in the tour: only ```sh (run) and "
                                "```text (its output) may appear there"
                                % (path, open_at + 1, lang))
            continue
        if line.strip():
            last_kind = "prose"
        i += 1
    return [tuple(b) for b in blocks]


def broken_links(path):
    """Relative Markdown links in path, [text](target), whose target does
    not exist beside it: (line, target)."""
    base = os.path.dirname(os.path.abspath(path))
    bad = []
    for n, line in enumerate(open(path, encoding="utf-8"), 1):
        for target in re.findall(r"\]\(([^)\s]+)\)", line):
            if re.match(r"^[a-z]+:", target) or target.startswith("#"):
                continue
            if not os.path.exists(os.path.join(base, target.split("#")[0])):
                bad.append((n, target))
    return bad


def matches(expected, got):
    """Whether the got lines match the expected ones ('...' wildcards)."""
    def line_re(e):
        return re.compile("^" + ".*".join(re.escape(p) for p in e.split("...")) + "$")
    pats = [None if e == "..." else line_re(e) for e in expected]
    # Backtracking over the line wildcards; tours are short.
    memo = {}

    def m(i, j):
        key = (i, j)
        if key in memo:
            return memo[key]
        if i == len(pats):
            r = j == len(got)
        elif pats[i] is None:
            r = any(m(i + 1, k) for k in range(j, len(got) + 1))
        else:
            r = j < len(got) and bool(pats[i].match(got[j])) and m(i + 1, j + 1)
        memo[key] = r
        return r
    return m(0, 0)


def script(blocks, run):
    """The bash script: each block's stdout and stderr go to RUN/N.out and
    RUN/N.err; RUN/failed gets 'block status line' when a command fails.
    Returns (text, {script line: readme line})."""
    out = [
        "set -e -o pipefail",
        "__tour_run=%s" % sh_quote(run),
        "trap 'printf \"%s %s %s\\n\" \"$__tour_block\" \"$?\" \"$LINENO\" "
        "> \"$__tour_run/failed\"' ERR",
    ]
    where = {}
    for n, (readme_line, code, _, _) in enumerate(blocks, 1):
        out.append("__tour_block=%d" % n)
        out.append("{")
        for k, line in enumerate(code.split("\n")):
            out.append(line)
            where[len(out)] = readme_line + k
        out.append("} > \"$__tour_run/%d.out\" 2> \"$__tour_run/%d.err\" < /dev/null" % (n, n))
        out.append(": > \"$__tour_run/%d.done\"" % n)
    return "\n".join(out) + "\n", where


def sh_quote(s):
    return "'" + s.replace("'", "'\\''") + "'"


def main():
    readme, root, run = sys.argv[1:4]
    name = os.path.basename(readme)
    passed = failed = 0

    def ok(msg):
        nonlocal passed
        passed += 1
        print("ok   " + msg)

    def bad(msg):
        nonlocal failed
        failed += 1
        print("FAIL " + msg)

    try:
        blocks = parse(readme)
    except TourError as e:
        bad(str(e))
        print("%d passed, %d failed" % (passed, failed))
        return 1
    # A tour that lost its blocks or its outputs would pass vacuously.
    n_shown = sum(1 for b in blocks if b[2] is not None)
    if len(blocks) >= 5 and n_shown >= 3:
        ok("the tour has %d shell blocks, %d with their output" % (len(blocks), n_shown))
    else:
        bad("the tour has only %d shell blocks and %d outputs" % (len(blocks), n_shown))

    # The README and the notes it sends readers to point only at files
    # that exist.
    docs = os.path.join(os.path.dirname(os.path.abspath(readme)), "docs")
    for doc in (readme, os.path.join(docs, "DESIGN.md"), os.path.join(docs, "BENCHMARKS.md")):
        if not os.path.exists(doc):
            bad("%s does not exist" % doc)
            continue
        links = broken_links(doc)
        if links:
            bad("%s links to missing files: %s" % (os.path.basename(doc), ", ".join(
                "line %d: %s" % l for l in links)))
        else:
            ok("every relative link in %s resolves" % os.path.basename(doc))

    text, where = script(blocks, run)
    path = os.path.join(run, "tour.sh")
    with open(path, "w") as f:
        f.write(text)
    with open(os.path.join(run, "shell.log"), "w") as log:
        try:
            rc = subprocess.call(["bash", "--noprofile", "--norc", path], cwd=root,
                                 stdin=subprocess.DEVNULL, stdout=log, stderr=log,
                                 timeout=TIMEOUT_S)
        except subprocess.TimeoutExpired:
            rc = None
    failure = None
    fpath = os.path.join(run, "failed")
    if os.path.exists(fpath):
        parts = open(fpath).read().split()
        failure = (int(parts[0]), int(parts[1]), int(parts[2]))

    def file_text(name):
        p = os.path.join(run, name)
        return open(p, errors="replace").read() if os.path.exists(p) else ""

    not_run = []
    for n, (readme_line, code, expected, text_line) in enumerate(blocks, 1):
        label = "%s:%d (block %d)" % (name, readme_line, n)
        done = os.path.exists(os.path.join(run, "%d.done" % n))
        if not done:
            if failure and failure[0] == n:
                line = where.get(failure[2], readme_line)
                bad("%s: the command at %s:%d exited with status %d:\n    %s\n"
                    "  its stderr:\n%s" % (label, name, line,
                                          failure[1], open(readme).read().split("\n")[line - 1],
                                          indent(file_text("%d.err" % n))))
            elif rc is None and (n == 1 or os.path.exists(os.path.join(run, "%d.done" % (n - 1)))):
                bad("%s: still running after %d s (hung?); stderr:\n%s"
                    % (label, TIMEOUT_S, indent(file_text("%d.err" % n))))
            elif n == 1 or os.path.exists(os.path.join(run, "%d.done" % (n - 1))):
                bad("%s: the shell stopped here (exit %s):\n%s"
                    % (label, rc, indent(file_text("shell.log") + file_text("%d.err" % n))))
            else:
                not_run.append(n)
            continue
        ok("%s runs" % label)
        if expected is None:
            continue
        got = file_text("%d.out" % n).split("\n")
        if got and got[-1] == "":
            got.pop()
        if matches(expected, got):
            ok("%s prints what %s:%d shows" % (label, name, text_line))
        else:
            diff = difflib.unified_diff(expected, got, "%s:%d (expected)" % (name, text_line),
                                        "what the block printed", lineterm="")
            bad("%s prints something else than %s:%d shows:\n%s\n  its stderr:\n%s"
                % (label, name, text_line, indent("\n".join(diff)),
                   indent(file_text("%d.err" % n))))
    if not_run:
        bad("blocks %d..%d of %d not run: an earlier block failed"
            % (not_run[0], not_run[-1], len(blocks)))
    if rc == 0 and failure is None:
        ok("the whole tour ran (exit 0)")
    else:
        bad("the tour's shell exited with %s" % ("a timeout" if rc is None else rc))
    print("%d passed, %d failed" % (passed, failed))
    return 1 if failed else 0


def indent(s):
    s = s.rstrip("\n")
    return "\n".join("    " + l for l in s.split("\n")) if s else "    (empty)"


if __name__ == "__main__":
    sys.exit(main())
