#!/usr/bin/env python3
"""Count the public API items of the driver crates from rustdoc's JSON output.

Usage: python3 tools/public-api-items.py [PACKAGE ...]   (default: the six driver crates)

Needs a nightly toolchain (`rustup toolchain install nightly --profile minimal`): rustdoc's JSON
output is unstable. Builds with every feature into target/public-api-json.

Counted, once each however many paths reach them: modules, types, traits, functions, constants,
statics and macros reachable from the crate root; inherent methods and associated constants;
public fields and enum variants. Trait implementations are not counted (the trait is). "paths" counts
every public path to a module-level item, so an item re-exported beside its public module counts
twice there.
"""
import json
import os
import subprocess
import sys

DRIVERS = ["bosch-bmp280", "bosch-bmx055", "pololu-maestro", "neo-m8t", "dima-sensorboard", "xbee-driver"]
TARGET = os.path.join("target", "public-api-json")


def rustdoc_json(package):
    subprocess.run(
        ["cargo", "+nightly", "rustdoc", "-q", "-p", package, "--all-features", "--lib", "--",
         "-Z", "unstable-options", "--output-format", "json"],
        check=True, env=dict(os.environ, CARGO_TARGET_DIR=TARGET))
    with open(os.path.join(TARGET, "doc", package.replace("-", "_") + ".json")) as f:
        return json.load(f)


def count(doc):
    index = doc["index"]
    items, paths = set(), 0

    def kind(item):
        return next(iter(item["inner"]))

    def visit_member(item_id):
        item = index.get(str(item_id))
        if item is None or item["crate_id"] != 0 or item["id"] in items:
            return
        items.add(item["id"])
        k = kind(item)
        inner = item["inner"][k]
        if k == "struct":
            fields = inner["kind"].get("plain", {}).get("fields", []) if isinstance(inner["kind"], dict) else []
            tuple_fields = inner["kind"].get("tuple", []) if isinstance(inner["kind"], dict) else []
            for field in fields + [f for f in tuple_fields if f is not None]:
                visit_member(field)
        if k == "enum":
            for variant in inner["variants"]:
                visit_member(variant)
        if k in ("struct", "enum", "union"):
            for impl_id in inner["impls"]:
                impl = index.get(str(impl_id))
                if impl is None:
                    continue
                body = impl["inner"]["impl"]
                if body["trait"] is None and not body.get("is_synthetic") and body.get("blanket_impl") is None:
                    for member in body["items"]:
                        visit_member(member)
        if k == "trait":
            for member in inner["items"]:
                visit_member(member)

    def visit_module(module_id, seen):
        nonlocal paths
        if module_id in seen:
            return
        seen.add(module_id)
        for item_id in index[str(module_id)]["inner"]["module"]["items"]:
            item = index.get(str(item_id))
            if item is None:
                continue
            target = item
            if kind(item) == "use":
                use = item["inner"]["use"]
                if use["id"] is None or str(use["id"]) not in index:
                    continue
                target = index[str(use["id"])]
                if use.get("is_glob"):
                    if kind(target) == "module":
                        visit_module(target["id"], seen)
                    continue
            if target["crate_id"] != 0:
                continue
            paths += 1
            if kind(target) == "module":
                items.add(target["id"])
                visit_module(target["id"], seen)
            else:
                visit_member(target["id"])

    visit_module(doc["root"], set())
    return len(items), paths


def main():
    for package in sys.argv[1:] or DRIVERS:
        n, p = count(rustdoc_json(package))
        print(f"{package:18} items {n:4}  paths {p:4}")


if __name__ == "__main__":
    main()
