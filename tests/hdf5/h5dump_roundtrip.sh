#!/usr/bin/env bash
# h5dump reads volcl-compressed datasets with only HDF5_PLUGIN_PATH set: binary dumps equal the raw copies,
# and a corrupted chunk makes h5dump fail with the filter's message.
# Usage: h5dump_roundtrip.sh PLUGIN_DIR EXAMPLE_EXE CORRUPT_EXE WORK_DIR
set -euo pipefail
plugin_dir=$1 example=$2 corrupt=$3 work=$4
rm -rf "$work" && mkdir -p "$work" && cd "$work"
run() { env -u LD_LIBRARY_PATH -u HDF5_PLUGIN_PATH HDF5_PLUGIN_PATH="$plugin_dir" "$@"; }

run "$example" data.h5
for pair in lossless_u16:raw_u16 lossless_f32:raw_f32 lossless_series_u8:raw_series_u8; do
  packed=${pair%%:*} raw=${pair##*:}
  run h5dump -d "/$packed" -b LE -o "$packed.bin" data.h5 >/dev/null
  run h5dump -d "/$raw" -b LE -o "$raw.bin" data.h5 >/dev/null
  cmp "$packed.bin" "$raw.bin"
  echo "h5dump /$packed equals /$raw ($(stat -c %s "$raw.bin") bytes)"
done
# The text dump names the filter and its parameters.
run h5dump -p -H -d /max_error_f32 data.h5 | grep -q "USER_DEFINED_FILTER"
run h5dump -p -H -d /max_error_f32 data.h5 | grep -q "FILTER_ID 420"
# Without the plugin the data cannot be read (so the reads above did go through the filter).
if env -u HDF5_PLUGIN_PATH HDF5_PLUGIN_PATH=/nonexistent h5dump -d /lossless_u16 -b LE -o none.bin data.h5 >/dev/null 2>&1; then
  echo "h5dump read a filtered dataset without the plugin" >&2; exit 1
fi

cp data.h5 corrupt.h5
run "$corrupt" corrupt.h5 lossless_u16
if run h5dump --enable-error-stack -d /lossless_u16 -b LE -o corrupt.bin corrupt.h5 >out.txt 2>err.txt; then
  echo "h5dump read a corrupted chunk without an error" >&2; exit 1
fi
grep -q "volcl filter (decode)" err.txt || { echo "h5dump's error does not name the volcl filter:" >&2; cat err.txt >&2; exit 1; }
echo "corrupted chunk: h5dump fails with: $(grep -m1 -o 'volcl filter (decode)[^"]*' err.txt)"
