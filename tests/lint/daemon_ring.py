#!/usr/bin/python3
"""daemon_ring.py - the largest ring among the daemon's files.

A ring is a strongly connected component of the call graph between object
files: file A points at file B when A uses a symbol B defines (from `nm`:
A's undefined symbols against B's defined global ones).  Files in a ring
cannot be understood, tested or linked apart, so the ring may shrink but
must never grow: this prints every ring of two files or more, largest
first, with the symbols that close it, and exits 1 when the largest has
more than --max files (3 today: conn, conn_read, dispatch).

It reads only the object files it is given (make passes build/daemon/*.o)
and writes only to stdout and stderr; it must not build anything.

Usage: daemon_ring.py [--max N] FILE.o...
"""
import argparse
import os
import subprocess
import sys


def symbols(objs):
    """Maps each object to (defined global symbols, undefined symbols)."""
    out = subprocess.run(["nm", "-A", "-g"] + objs, check=True, capture_output=True,
                         text=True).stdout
    table = {o: (set(), set()) for o in objs}
    for line in out.splitlines():
        # "path.o:0000000000000000 T name" or "path.o:                 U name"
        path, _, rest = line.partition(":")
        fields = rest.split()
        if path not in table or len(fields) < 2:
            continue
        kind, name = fields[-2], fields[-1]
        table[path][1 if kind == "U" else 0].add(name)
    return table


def graph(table):
    """File -> {file it uses: the symbols it uses from it}."""
    owner = {}
    for o, (defined, _) in table.items():
        for name in defined:
            owner.setdefault(name, o)
    edges = {o: {} for o in table}
    for o, (_, undefined) in table.items():
        for name in undefined:
            b = owner.get(name)
            if b is not None and b != o:
                edges[o].setdefault(b, set()).add(name)
    return edges


def rings(edges):
    """The strongly connected components (Tarjan's algorithm, iterative so
    that a long chain of files cannot overflow Python's stack)."""
    index, low, on_stack, stack, comps = {}, {}, set(), [], []
    counter = 0
    for root in sorted(edges):
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(edges[w]))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                u = work[-1][0]
                low[u] = min(low[u], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                comps.append(sorted(comp))
    return sorted(comps, key=lambda c: (-len(c), c))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--max", type=int, default=3, help="the most files the largest ring may hold")
    ap.add_argument("objs", nargs="+", metavar="FILE.o")
    args = ap.parse_args()
    missing = [o for o in args.objs if not os.path.isfile(o)]
    if missing:
        print("daemon_ring: no such object file: %s (build the daemon first)" % missing[0],
              file=sys.stderr)
        return 2
    edges = graph(symbols(args.objs))
    big = [c for c in rings(edges) if len(c) > 1]
    name = lambda o: os.path.splitext(os.path.basename(o))[0]
    for comp in big:
        print("daemon_ring: a ring of %d files: %s" % (len(comp), " ".join(map(name, comp))))
        for a in comp:
            for b in comp:
                if b in edges[a]:
                    used = sorted(edges[a][b])
                    more = " (+%d more)" % (len(used) - 3) if len(used) > 3 else ""
                    print("  %s -> %s: %s%s" % (name(a), name(b), " ".join(used[:3]), more))
    largest = len(big[0]) if big else 1
    if largest > args.max:
        print("daemon_ring: the largest ring holds %d files, more than %d: cut the new "
              "dependency above (a callback or a table, not a call back into the ring)"
              % (largest, args.max))
        return 1
    print("daemon_ring: the largest ring holds %d of %d files (at most %d)"
          % (largest, len(args.objs), args.max))
    return 0


if __name__ == "__main__":
    sys.exit(main())
