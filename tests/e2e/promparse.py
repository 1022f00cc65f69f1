#!/usr/bin/python3
"""A strict parser for the Prometheus text exposition format (0.0.4).

Written from the format's documentation, apart from the C code that
prints it (client/cli/stats_format.c).  Usage:

  promparse.py FILE        parse; print one line per sample as
                           "name{labels} value"; exit 1 with the line
                           number and the problem on the first violation
  promparse.py --selftest  check that known-bad inputs are refused

Stricter than the scrapers on purpose (what qmc prints should never lean
on their leniency): every family has exactly one HELP and one TYPE, both
before its samples; a family's samples are contiguous; no blank lines, no
other comments, no timestamps, no duplicate series; counters are >= 0 and
named *_total; a histogram has _bucket series with le in increasing order
ending at +Inf, cumulative counts, _sum and _count, and +Inf == _count.
"""
import math
import re
import sys

NAME = re.compile(r"[a-zA-Z_:][a-zA-Z0-9_:]*\Z")
LABEL = re.compile(r"[a-zA-Z_][a-zA-Z0-9_]*\Z")
FLOAT = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?\Z")
TYPES = ("counter", "gauge", "histogram", "summary", "untyped")


class Bad(Exception):
    pass


def parse_value(text):
    if text in ("+Inf", "Inf"):
        return math.inf
    if text == "-Inf":
        return -math.inf
    if text == "NaN":
        return math.nan
    if not FLOAT.match(text):
        raise Bad("value %r is not a float" % text)
    return float(text)


def parse_labels(text):
    """text is what lies between { and }; returns a list of (name, value)."""
    out, i = [], 0
    while i < len(text):
        m = re.match(r"([a-zA-Z_][a-zA-Z0-9_]*)=\"", text[i:])
        if not m:
            raise Bad("bad label at %r" % text[i:])
        name = m.group(1)
        if name.startswith("__"):
            raise Bad("label name %r is reserved" % name)
        i += m.end()
        val = []
        while True:
            if i >= len(text):
                raise Bad("unterminated label value")
            c = text[i]
            if c == "\\":
                if i + 1 >= len(text) or text[i + 1] not in '\\"n':
                    raise Bad("bad escape in a label value")
                val.append({"\\": "\\", '"': '"', "n": "\n"}[text[i + 1]])
                i += 2
            elif c == '"':
                i += 1
                break
            elif c == "\n":
                raise Bad("newline in a label value")
            else:
                val.append(c)
                i += 1
        if any(n == name for n, _ in out):
            raise Bad("label %r twice" % name)
        out.append((name, "".join(val)))
        if i < len(text):
            if text[i] != ",":
                raise Bad("expected ',' between labels")
            i += 1
            if i == len(text):
                raise Bad("trailing ',' in labels")
    return out


def split_sample(line):
    """'name{labels} value' -> (name, labels, value text)."""
    m = re.match(r"([^{\s]+)(\{(.*)\})? (\S+)\Z", line)
    if not m:
        raise Bad("not 'name[{labels}] value': %r" % line)
    name, labels, value = m.group(1), m.group(3), m.group(4)
    if not NAME.match(name):
        raise Bad("bad metric name %r" % name)
    return name, parse_labels(labels) if labels is not None else [], value


def family_of(sample_name, families):
    """The family a sample belongs to (histogram suffixes stripped)."""
    if sample_name in families:
        return sample_name
    for suffix in ("_bucket", "_sum", "_count"):
        if sample_name.endswith(suffix):
            base = sample_name[: -len(suffix)]
            if families.get(base, {}).get("type") in ("histogram", "summary"):
                return base
    return None


def check_family(name, fam):
    if fam["type"] is None or fam["help"] is None:
        raise Bad("family %s lacks HELP or TYPE" % name)
    if not fam["samples"]:
        raise Bad("family %s has no samples" % name)
    if fam["type"] == "counter":
        if not name.endswith("_total"):
            raise Bad("counter %s is not named *_total" % name)
        for sname, _, v in fam["samples"]:
            if sname != name or not (v >= 0) or math.isinf(v):
                raise Bad("counter %s: bad sample %s %r" % (name, sname, v))
    elif fam["type"] in ("gauge", "untyped"):
        for sname, _, _ in fam["samples"]:
            if sname != name:
                raise Bad("%s %s: sample named %s" % (fam["type"], name, sname))
    elif fam["type"] == "histogram":
        buckets = [(l, v) for s, l, v in fam["samples"] if s == name + "_bucket"]
        sums = [v for s, _, v in fam["samples"] if s == name + "_sum"]
        counts = [v for s, _, v in fam["samples"] if s == name + "_count"]
        if len(sums) != 1 or len(counts) != 1 or not buckets:
            raise Bad("histogram %s needs buckets, one _sum and one _count" % name)
        prev_le, prev_n = -math.inf, 0
        for labels, v in buckets:
            les = [val for n, val in labels if n == "le"]
            if len(les) != 1:
                raise Bad("histogram %s: a bucket without le" % name)
            le = parse_value(les[0])
            if math.isnan(le) or le <= prev_le:
                raise Bad("histogram %s: le %s not above the previous" % (name, les[0]))
            if v < prev_n or v != int(v):
                raise Bad("histogram %s: bucket le=%s not cumulative" % (name, les[0]))
            prev_le, prev_n = le, v
        if prev_le != math.inf:
            raise Bad("histogram %s: the last bucket is not le=\"+Inf\"" % name)
        if prev_n != counts[0]:
            raise Bad("histogram %s: +Inf bucket %r != _count %r" % (name, prev_n, counts[0]))
        if sums[0] < 0:
            raise Bad("histogram %s: negative _sum" % name)
        order = [s for s, _, _ in fam["samples"]]
        if order[-2:] != [name + "_sum", name + "_count"]:
            raise Bad("histogram %s: _sum and _count must follow the buckets" % name)


def parse(text):
    """Returns [(name, labels, value)]; raises Bad('line N: ...')."""
    if not text.endswith("\n"):
        raise Bad("the last line does not end with a newline")
    families, order, samples, seen = {}, [], [], set()
    current = None
    for n, line in enumerate(text[:-1].split("\n"), 1):
        try:
            if line == "":
                raise Bad("blank line")
            if line.startswith("#"):
                m = re.match(r"# (HELP|TYPE) (\S+) (.*)\Z", line)
                if not m:
                    raise Bad("a comment other than HELP or TYPE: %r" % line)
                kind, name, rest = m.groups()
                if not NAME.match(name):
                    raise Bad("bad metric name %r" % name)
                if name in families and families[name]["samples"]:
                    raise Bad("%s for %s after its samples" % (kind, name))
                fam = families.setdefault(name, {"type": None, "help": None, "samples": []})
                if name not in order:
                    if current is not None:
                        check_family(current, families[current])
                    order.append(name)
                    current = name
                elif name != current:
                    raise Bad("family %s resumed" % name)
                key = kind.lower()
                if fam[key] is not None:
                    raise Bad("second %s for %s" % (kind, name))
                if kind == "TYPE" and rest not in TYPES:
                    raise Bad("unknown type %r" % rest)
                if kind == "HELP" and re.search(r"\\[^\\n]|\\\Z", rest):
                    raise Bad("bad escape in HELP")
                fam[key] = rest
                continue
            name, labels, vtext = split_sample(line)
            fname = family_of(name, families)
            if fname is None:
                raise Bad("sample %s before its HELP/TYPE" % name)
            if fname != current:
                raise Bad("sample of %s outside its family's block" % fname)
            series = (name, tuple(sorted(labels)))
            if series in seen:
                raise Bad("duplicate series %s%s" % (name, labels))
            seen.add(series)
            v = parse_value(vtext)
            families[fname]["samples"].append((name, labels, v))
            samples.append((name, labels, v))
        except Bad as e:
            raise Bad("line %d: %s" % (n, e)) from None
    if current is None:
        raise Bad("no metrics")
    check_family(current, families[current])
    return samples, families


GOOD = """# HELP a_total A counter.
# TYPE a_total counter
a_total 3
# HELP h A histogram.
# TYPE h histogram
h_bucket{le="0.5"} 1
h_bucket{le="+Inf"} 2
h_sum 1.25
h_count 2
"""

BAD = {
    "no final newline": GOOD[:-1],
    "blank line": GOOD.replace("a_total 3\n", "a_total 3\n\n"),
    "TYPE after sample": GOOD.replace("# TYPE a_total counter\na_total 3\n",
                                      "a_total 3\n# TYPE a_total counter\n"),
    "no HELP": GOOD.replace("# HELP a_total A counter.\n", ""),
    "unknown type": GOOD.replace("counter\n", "countr\n"),
    "counter not _total": GOOD.replace("a_total", "a"),
    "negative counter": GOOD.replace("a_total 3", "a_total -3"),
    "bad value": GOOD.replace("a_total 3", "a_total three"),
    "timestamp": GOOD.replace("a_total 3", "a_total 3 1700000000"),
    "bad name": GOOD.replace("a_total", "9a_total"),
    "not cumulative": GOOD.replace('h_bucket{le="+Inf"} 2', 'h_bucket{le="+Inf"} 0'),
    "no +Inf": GOOD.replace('h_bucket{le="+Inf"} 2\n', ""),
    "le out of order": GOOD.replace('{le="0.5"}', '{le="2"}').replace(
        'h_bucket{le="+Inf"}', 'h_bucket{le="1"} 1\nh_bucket{le="+Inf"}'),
    "+Inf != count": GOOD.replace("h_count 2", "h_count 3"),
    "no _sum": GOOD.replace("h_sum 1.25\n", ""),
    "family resumed": GOOD + "a_total 4\n",
    "duplicate series": GOOD.replace("a_total 3\n", "a_total 3\na_total 3\n"),
    "unquoted label": GOOD.replace('{le="0.5"}', "{le=0.5}"),
    "trailing comma": GOOD.replace('{le="0.5"}', '{le="0.5",}'),
    "bad escape": GOOD.replace('{le="0.5"}', '{le="0.5",x="\\q"}'),
    "stray comment": "# hello\n" + GOOD,
}


def selftest():
    parse(GOOD)
    failures = 0
    for what, text in BAD.items():
        try:
            parse(text)
        except Bad:
            continue
        print("selftest: accepted %s" % what)
        failures += 1
    print("selftest: %d bad inputs refused, %d accepted" % (len(BAD) - failures, failures))
    return 1 if failures else 0


def main():
    if sys.argv[1:] == ["--selftest"]:
        sys.exit(selftest())
    with open(sys.argv[1], encoding="utf-8") as f:
        text = f.read()
    try:
        samples, families = parse(text)
    except Bad as e:
        print("promparse: %s" % e)
        sys.exit(1)
    for name, labels, v in samples:
        lab = ",".join('%s="%s"' % kv for kv in labels)
        print("%s%s %s" % (name, "{" + lab + "}" if lab else "", repr(v)))
    for name in families:
        print("# family %s %s" % (name, families[name]["type"]))


if __name__ == "__main__":
    main()
