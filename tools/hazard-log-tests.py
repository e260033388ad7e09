#!/usr/bin/env python3
"""Checks that every test the hazard log (docs/safety.md) names exists.

Reads the last column of every table row, takes each backticked name that looks like a test
(`crate: module::path::test_name`, `file.rs: test_name`, `…test_name` for one more test of the
same module), and looks for `fn test_name` in the workspace's Rust sources. Invariants marked
`(dst)` are looked up among the names `dima dst` lists (`name: "…"` in its sources). Exits 1
and names what is missing.
"""
import pathlib
import re
import sys

root = pathlib.Path(__file__).resolve().parent.parent
log = (root / "docs" / "safety.md").read_text()
sources = "\n".join(
    p.read_text(errors="replace")
    for p in root.rglob("*.rs")
    if "target" not in p.parts and "fuzz" not in p.parts[:2]
)
defined = set(re.findall(r"\bfn\s+([a-z_][a-z0-9_]*)", sources))

missing = []
checked = 0
for line in log.splitlines():
    if not line.startswith("|") or line.startswith("|---") or line.startswith("| #"):
        continue
    tests = line.rstrip().rstrip("|").split("|")[-1]
    for dst_part in re.findall(r"\(dst\)\s*((?:`[a-z_]+`(?:,\s*)?)+)", tests):
        for name in re.findall(r"`([a-z_]+)`", dst_part):
            checked += 1
            if f'"{name}"' not in sources:
                missing.append(f"dst invariant {name}")
    tests = re.sub(r"\(dst\)\s*((?:`[a-z_]+`(?:,\s*)?)+)", "", tests)
    for token in re.findall(r"`([^`]+)`", tests):
        name = re.split(r"::|: |…", token)[-1].strip()
        if not re.fullmatch(r"[a-z][a-z0-9_]{8,}", name):
            continue
        checked += 1
        if name not in defined:
            missing.append(f"test {name} ({token})")

for m in missing:
    print(f"docs/safety.md names a {m} that does not exist")
print(f"hazard log: {checked} tests and invariants named, {len(missing)} missing")
sys.exit(1 if missing else 0)
