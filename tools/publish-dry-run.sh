#!/usr/bin/env bash
# Dry run of publishing the six driver crates, in their publish order (drivers/PUBLISHING.md):
# nothing is uploaded. Exits non-zero at the first crate that would fail to publish.
set -euo pipefail
cd "$(dirname "$0")/.."

# Crates with no dependency on another crate of this workspace, in publish order.
independent=(neo-m8t bosch-bmx055 bosch-bmp280 pololu-maestro xbee-driver)
# dima-sensorboard needs neo-m8t and bosch-bmx055 on crates.io first.
dependent=dima-sensorboard
dependent_needs=(neo-m8t bosch-bmx055)

start=$SECONDS
for crate in "${independent[@]}"; do
  echo "--- $crate: cargo publish --dry-run"
  cargo publish --dry-run --locked -p "$crate"
done

echo "--- $dependent (after ${dependent_needs[*]})"
cargo_minor=$(cargo --version | sed -E 's/^cargo 1\.([0-9]+).*/\1/')
if [ "$cargo_minor" -ge 90 ]; then
  # Packaged together, the two unpublished dependencies resolve from their .crate files.
  args=()
  for crate in "${dependent_needs[@]}" "$dependent"; do args+=(-p "$crate"); done
  cargo publish --dry-run --locked "${args[@]}"
else
  # Older cargo resolves every dependency against crates.io, where the two are not yet: list
  # the packaged files only, and verify after publishing them.
  echo "cargo older than 1.90: listing $dependent's package only"
  cargo package --list --locked -p "$dependent"
fi
echo "publish dry run: $((SECONDS - start)) s"
