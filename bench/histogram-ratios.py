#!/usr/bin/env python3
"""Percentiles of cyclictest-format histograms (`-h`: 1 µs buckets, `# Histogram Overflows`),
dima beside cyclictest per run, and their ratios.

Usage: histogram-ratios.py RUN.dima.hist [...]   (RUN.cyclictest.hist next to each)
       histogram-ratios.py --p50-p99 FILE.hist       (prints "p50/p99" of one histogram)
"""
import math
import re
import sys


def parse(path):
    """Bucket counts (µs -> n), overflows, and cyclictest's missed-period note if any."""
    buckets, overflows = {}, 0
    with open(path) as f:
        for line in f:
            m = re.match(r"^(\d{6})\s+(\d+)", line)
            if m:
                n = int(m.group(2))
                if n:
                    buckets[int(m.group(1))] = buckets.get(int(m.group(1)), 0) + n
            m = re.match(r"^# Histogram Overflows:\s+(\d+)", line)
            if m:
                overflows += int(m.group(1))
    return buckets, overflows


def percentile(buckets, overflows, p):
    total = sum(buckets.values()) + overflows
    if total == 0:
        return math.nan
    rank = math.ceil(p / 100 * total)
    seen = 0
    for us in sorted(buckets):
        seen += buckets[us]
        if seen >= rank:
            return us
    return math.inf  # in the overflow


def missed(log_path):
    try:
        text = open(log_path).read()
    except OSError:
        return "-"
    m = re.search(r"(\d+) missed periods", text)
    return m.group(1) if m else "-"


def row(name, path):
    b, o = parse(path)
    n = sum(b.values()) + o
    ps = [percentile(b, o, p) for p in (50, 99, 99.9, 100)]
    return n, ps


def fmt(v):
    return "-" if isinstance(v, float) and math.isnan(v) else ("ovf" if v == math.inf else str(v))


if sys.argv[1:2] == ["--p50-p99"]:
    b, o = parse(sys.argv[2])
    print(f"{fmt(percentile(b, o, 50))}/{fmt(percentile(b, o, 99))}")
    sys.exit(0)

print(f"{'run':<40} {'who':<10} {'n':>7} {'p50':>6} {'p99':>6} {'p99.9':>6} {'max':>6} {'missed':>6}")
ratios = {"p50": [], "p99": []}
for dima_path in sys.argv[1:]:
    run = dima_path[: -len(".dima.hist")]
    name = run.rsplit("/", 1)[-1]
    dn, dps = row(name, dima_path)
    cn, cps = row(name, run + ".cyclictest.hist")
    print(f"{name:<40} {'dima':<10} {dn:>7} " + " ".join(f"{fmt(v):>6}" for v in dps) + f" {missed(run + '.dima.log'):>6}")
    print(f"{'':<40} {'cyclictest':<10} {cn:>7} " + " ".join(f"{fmt(v):>6}" for v in cps) + f" {'-':>6}")
    r = [d / c if c and math.isfinite(d) and math.isfinite(c) else math.nan for d, c in zip(dps, cps)]
    print(f"{'':<40} {'ratio':<10} {'':>7} " + " ".join(f"{v:>6.2f}" for v in r))
    ratios["p50"].append(r[0])
    ratios["p99"].append(r[1])
for k, v in ratios.items():
    v = [x for x in v if math.isfinite(x)]
    if v:
        print(f"ratio dima/cyclictest {k}: median {sorted(v)[len(v) // 2]:.2f} (min {min(v):.2f}, max {max(v):.2f}) over {len(v)} runs")
