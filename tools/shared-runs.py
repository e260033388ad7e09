#!/usr/bin/env python3
"""Find runs of six or more lines shared between a driver crate's blocking and async code.

Usage: python3 tools/shared-runs.py [MIN_LINES]   (default 6); exits 1 if any run is found.

A crate's async code is every source file whose name or directory says so (`asynch`, `async`)
or, for crates that generate both from one source, nothing: then there is nothing to share.
Lines are normalised before comparing (whitespace collapsed, `.await`, `async `, `Async` and
`asynch::` removed; blank lines and comment-only lines dropped), so text that differs only in
those words counts as shared.
"""
import pathlib
import re
import sys

MIN = int(sys.argv[1]) if len(sys.argv) > 1 else 6


def normalise(line):
    line = line.split("//", 1)[0]
    line = re.sub(r"\.await|\basync\s+|Async|asynch::|embedded_hal_async", "", line)
    line = re.sub(r"embedded_hal\b", "", line)
    return " ".join(line.split())


def lines_of(path):
    out = []
    for n, raw in enumerate(path.read_text().splitlines(), 1):
        norm = normalise(raw)
        if norm and norm not in ("{", "}", "};", ")", "});", "Ok(())", "]"):
            out.append((norm, path, n))
    return out


def shared_runs(blocking, asynchronous):
    seen = {}
    for i in range(len(blocking) - MIN + 1):
        seen.setdefault(tuple(l for l, _, _ in blocking[i:i + MIN]), (blocking[i][1], blocking[i][2]))
    runs = []
    previous_matched = False
    for j in range(len(asynchronous) - MIN + 1):
        key = tuple(l for l, _, _ in asynchronous[j:j + MIN])
        matched = key in seen
        # Consecutive matching windows are one run; report where each run starts.
        if matched and not previous_matched:
            runs.append((seen[key], (asynchronous[j][1], asynchronous[j][2])))
        previous_matched = matched
    return runs


def main():
    found = 0
    for crate in sorted(pathlib.Path("drivers").iterdir()):
        files = sorted((crate / "src").rglob("*.rs"))
        is_async = lambda p: re.search(r"async", str(p.relative_to(crate / "src")))
        asynchronous = [l for p in files if is_async(p) for l in lines_of(p)]
        blocking = [l for p in files if not is_async(p) for l in lines_of(p)]
        runs = shared_runs(blocking, asynchronous)
        print(f"{crate.name:12} async lines {len(asynchronous):5}  shared runs of {MIN}+ lines: {len(runs)}")
        for (bp, bn), (ap, an) in runs[:20]:
            print(f"    {bp}:{bn}  ==  {ap}:{an}")
        found += len(runs)
    sys.exit(1 if found else 0)


if __name__ == "__main__":
    main()
