#!/usr/bin/env bash
# Regenerates docs/images/demo_phantom.png, the README's picture: the first image `volcl demo` writes.
# Usage: bash scripts/demo_image.sh [path/to/volcl]   (default build/volcl)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
volcl="${1:-$root/build/volcl}"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
"$volcl" -q demo -o "$out" > /dev/null
mkdir -p "$root/docs/images"
cp "$out/phantom.png" "$root/docs/images/demo_phantom.png"
echo "wrote $root/docs/images/demo_phantom.png"
