#!/usr/bin/env bash
# Builds each driver crate's STM32 example the way its README's "STM32" section says: a fresh
# project outside the workspace with the README's Cargo.toml, .cargo/config.toml and memory.x,
# and the crate's examples/stm32f4.rs as src/main.rs. The crate itself comes from this
# repository by path (the README's `<crate> = "0.1"` line is rewritten), everything else from
# crates.io. Then checks each ELF: a non-empty .vector_table whose reset vector is the entry
# point, and a non-zero entry point.
#
# Usage: bash tools/stm32-examples.sh [WORK_DIR]   (default: a new temporary directory)
# All projects share one CARGO_TARGET_DIR under WORK_DIR, so the HAL is built once.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
work=${1:-$(mktemp -d -t stm32-examples.XXXXXX)}
mkdir -p "$work"
export CARGO_TARGET_DIR="$work/target"
rustup target add thumbv7em-none-eabihf >/dev/null 2>&1 || true

start=$SECONDS
for dir in bmp280 bmx055 maestro neo-m8t sensorboard xbee; do
  crate_dir="$repo/drivers/$dir"
  crate=$(python3 -c 'import sys, tomllib; print(tomllib.load(open(sys.argv[1], "rb"))["package"]["name"])' "$crate_dir/Cargo.toml")
  project="$work/$crate-stm32"
  echo "--- $crate: $project"
  rm -rf "$project"
  mkdir -p "$project/src" "$project/.cargo"
  # The README's three files: the STM32 section's first toml block is Cargo.toml, the second
  # .cargo/config.toml, the text block memory.x.
  python3 - "$crate_dir/README.md" "$project" "$crate" "$crate_dir" <<'PY'
import re, sys
readme, project, crate, crate_dir = sys.argv[1:]
text = open(readme).read()
section = re.search(r'^## STM32.*?(?=^## |\Z)', text, re.S | re.M)
if not section:
    sys.exit(f"{readme}: no STM32 section")
blocks = re.findall(r'^```(\w*)\n(.*?)^```', section.group(0), re.S | re.M)
tomls = [body for lang, body in blocks if lang == "toml"]
texts = [body for lang, body in blocks if lang == "text"]
if len(tomls) != 2 or len(texts) != 1:
    sys.exit(f"{readme}: expected two toml blocks and one text block in the STM32 section")
manifest, config = tomls
line = re.compile(rf'^{re.escape(crate)} = "[^"]*"$', re.M)
if not line.search(manifest):
    sys.exit(f"{readme}: the STM32 Cargo.toml does not depend on {crate}")
manifest = line.sub(f'{crate} = {{ path = "{crate_dir}" }}', manifest)
open(f"{project}/Cargo.toml", "w").write(manifest)
open(f"{project}/.cargo/config.toml", "w").write(config)
open(f"{project}/memory.x", "w").write(texts[0])
PY
  cp "$crate_dir/examples/stm32f4.rs" "$project/src/main.rs"
  (cd "$project" && cargo build --release --quiet)
  elf="$CARGO_TARGET_DIR/thumbv7em-none-eabihf/release/$crate-stm32"
  python3 - "$elf" <<'PY'
import struct, sys
path = sys.argv[1]
data = open(path, "rb").read()
if data[:4] != b"\x7fELF" or data[4] != 1 or data[5] != 1:
    sys.exit(f"{path}: not a 32-bit little-endian ELF")
(e_type, e_machine, _, e_entry, _, e_shoff, _, _, _, _, e_shentsize, e_shnum, e_shstrndx) = \
    struct.unpack_from("<HHIIIIIHHHHHH", data, 16)
if e_machine != 40:
    sys.exit(f"{path}: not an ARM ELF (e_machine {e_machine})")
if e_entry == 0:
    sys.exit(f"{path}: entry point is 0")
sections = [struct.unpack_from("<IIIIIIIIII", data, e_shoff + i * e_shentsize) for i in range(e_shnum)]
names = sections[e_shstrndx][4]
def name(sh):
    start = names + sh[0]
    return data[start:data.index(b"\0", start)].decode()
vt = [sh for sh in sections if name(sh) == ".vector_table"]
if not vt or vt[0][5] < 8:
    sys.exit(f"{path}: no .vector_table (or shorter than the stack pointer and reset vector)")
addr, offset = vt[0][3], vt[0][4]
initial_sp, reset = struct.unpack_from("<II", data, offset)
if reset & ~1 != e_entry & ~1:
    sys.exit(f"{path}: reset vector {reset:#010x} is not the entry point {e_entry:#010x}")
print(f"{path}: entry {e_entry:#010x}, vector table at {addr:#010x} "
      f"({vt[0][5]} bytes), initial SP {initial_sp:#010x}")
PY
done
echo "stm32 examples: $((SECONDS - start)) s"
