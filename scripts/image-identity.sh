#!/usr/bin/env bash
# Renders every scene of the repository (assets/scenes, tests/data and the
# complete scene examples of docs/scene-format.md) at low spp, with the
# vectorised kernel and with --scalar, and prints one line per image:
# "<sha256 of the EXR>  <scene> <mode>". Run it with the binary before and
# after a change that must not alter images, and diff the two listings:
#
#   scripts/image-identity.sh target/release/plsr > before.txt
#   ... change ...
#   scripts/image-identity.sh target/release/plsr > after.txt
#   diff before.txt after.txt
#
# EXR files are byte-reproducible (see docs), so equal hashes mean equal
# pixels in every layer; the version in the header is masked, so builds of
# different versions compare too.
set -euo pipefail
bin=${1:?usage: image-identity.sh PLSR_BINARY [SPP]}
spp=${2:-2}
bin=$(realpath "$bin")
root=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$root"

scenes=()
while IFS= read -r f; do scenes+=("$f"); done < <(find assets/scenes tests/data -name '*.toml' | sort)

# The documentation's examples: each ```toml block holding a [camera] table
# is a complete scene, written beside the Cornell box so its relative paths resolve.
python3 - "$work" <<'PY'
import re, sys, pathlib
doc = pathlib.Path("docs/scene-format.md").read_text()
for i, block in enumerate(re.findall(r"```toml\n(.*?)```", doc, re.S)):
    if "[camera]" in block:
        pathlib.Path(sys.argv[1], f"doc-{i:02}.toml").write_text(block)
PY
for f in "$work"/doc-*.toml; do
  cp "$f" "assets/scenes/cornell/.identity-$(basename "$f")"
  scenes+=("assets/scenes/cornell/.identity-$(basename "$f")")
done
trap 'rm -rf "$work" assets/scenes/cornell/.identity-doc-*.toml' EXIT

for s in "${scenes[@]}"; do
  for mode in vectorised scalar; do
    flag=(); [ "$mode" = scalar ] && flag=(--scalar)
    out="$work/out.exr"
    rm -f "$out"
    if "$bin" render "$s" -o "$out" --spp "$spp" --quiet "${flag[@]}" 2>"$work/err"; then
      # The header names plsr's version; hash the file with it masked.
      echo "$(LC_ALL=C sed -e 's/plsr [0-9][0-9.]* (/plsr V (/' "$out" | sha256sum | cut -c1-64)  $s $mode"
    else
      echo "error: $(head -c 200 "$work/err" | tr '\n' ' ')  $s $mode"
    fi
  done
done
