#!/usr/bin/env bash
# The k-buffer measurements of docs/meshes.md: k against error and time on every shared mesh and the generated
# 1.57 M tet mesh at 512x512 (RMSE against the exact double reference; the centroid sort), the face order
# (render.sort) per mesh, the face-split knob on the meshes it changes, and the dynamic level of detail under the frame-time controller. Writes bench/results/meshes/kbuffer-*.csv.
# Usage: bench/kbuffer_sweep.sh [build-dir] [shared-data-dir]
set -euo pipefail
build=${1:-build}
data=${2:-../shared/data}/unstructured
out=bench/results/meshes
bench=$build/bench/volcl-bench-kbuffer
mkdir -p "$out"
uptime | tee "$out/kbuffer-load.txt"
meshes=()
for f in tetraMesh.vtk xsmall_turb.vtu kiefer/dataset.vtu bluntfinxyz.bin combxyz.bin; do
  [[ -e $data/$f ]] && meshes+=("$data/$f")
done
if ((${#meshes[@]})); then
  # The face order (render.sort) against error and time, one core: the centroid sort against the cells' orders.
  taskset -c 0 "$bench" --size 512 --runs 3 --k 2,6 --sort centroid,mpvo,convexified --rmse "${meshes[@]}" \
    > "$out/kbuffer-order.csv"
  uptime | tee -a "$out/kbuffer-load.txt"
  "$bench" --size 512 --runs 3 --k 2,4,6,8 --rmse "${meshes[@]}" > "$out/kbuffer-k-sweep.csv"
fi
if [[ -e $data/postxyz.bin ]]; then # energy: the density of the post is 1 everywhere
  taskset -c 0 "$bench" --size 512 --runs 3 --k 2,6 --sort centroid,convexified --rmse --q-var 4 \
    "$data/postxyz.bin" | tail -n +2 >> "$out/kbuffer-order.csv"
  "$bench" --size 512 --runs 3 --k 2,4,6,8 --rmse --q-var 4 "$data/postxyz.bin" | tail -n +2 >> "$out/kbuffer-k-sweep.csv"
  # the face-split knob: off against the default (error vs time)
  "$bench" --size 512 --runs 3 --k 2,6,8 --rmse --q-var 4 --split 0 0 "$data/postxyz.bin" > "$out/kbuffer-split-off.csv"
fi
[[ -e $data/bluntfinxyz.bin ]] &&
  "$bench" --size 512 --runs 3 --k 2,6,8 --rmse --split 0 0 "$data/bluntfinxyz.bin" | tail -n +2 >> "$out/kbuffer-split-off.csv"
[[ ${SKIP_ML:-0} == 1 ]] && exit 0 # SKIP_ML=1: only the shared meshes
"$bench" --size 512 --runs 3 --k 2,4,6,8 --rmse --ml 64 > "$out/kbuffer-ml64.csv"
uptime | tee -a "$out/kbuffer-load.txt"
# Dynamic level of detail on the 1.57 M tet mesh: the controller holds 400 ms frames while the camera orbits.
"$bench" --size 512 --runs 1 --k 6 --ml 64 --lod-target 400 --frames 30 > "$out/kbuffer-lod.csv"
uptime | tee -a "$out/kbuffer-load.txt"
