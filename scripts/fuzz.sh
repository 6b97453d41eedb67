#!/usr/bin/env bash
# Runs every fuzz target in turn (one fuzzer process at a time: the machine is shared).
#   scripts/fuzz.sh --build DIR --short          fixed executions per target, fixed seed (CI, seconds)
#   scripts/fuzz.sh --build DIR --runs N         N executions per target (long runs, e.g. 10000000)
#   scripts/fuzz.sh --build DIR --seconds S      S seconds per target
#   --only TARGET                                one target
#   --keep-corpus DIR                            libFuzzer's grown corpus persists in DIR/<target> across
#                                                runs (default: a temporary copy of the seeds, removed at exit)
# DIR is a build with -DVOLCL_FUZZ=ON: libFuzzer targets with clang (coverage-guided, reports cov/ft),
# replay-driver targets with GCC. Results go to stdout and, for long runs, to bench/results/reliability/fuzz-runs.csv
# (target, engine, executions, wall seconds, coverage, features, findings, CPU seconds, covered/total edges of
# the target's main parser file, the first that scripts/fuzz_coverage.py lists). A failing input is saved as
# crash-* in the working directory; keep it under fuzz/regressions/<target>/ once fixed.
set -euo pipefail
cd "$(dirname "$0")/.."
# Leak reports count as findings; only the third-party libraries in tests/lsan.supp are exempt.
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$PWD/tests/lsan.supp}"
build="build-fuzz"
mode="short"
count=0
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build="$2"; shift 2 ;;
    --short) mode="short"; shift ;;
    --runs) mode="runs"; count="$2"; shift 2 ;;
    --seconds) mode="seconds"; count="$2"; shift 2 ;;
    --only) only="$2"; shift 2 ;;
    --keep-corpus) keep=$(realpath -m "$2"); shift 2 ;; # absolute: the fuzzers run in a scratch directory
    *) echo "usage: scripts/fuzz.sh --build DIR [--short | --runs N | --seconds S] [--only TARGET] [--keep-corpus DIR]" >&2; exit 2 ;;
  esac
done
targets=$(cd "$build/fuzz" && ls fuzz_* 2>/dev/null | grep -v '\.' || true)
[ -n "$targets" ] || { echo "no fuzz targets in $build/fuzz (configure with -DVOLCL_FUZZ=ON)" >&2; exit 2; }
csv=bench/results/reliability/fuzz-runs.csv
[ "$mode" = short ] || mkdir -p "$(dirname "$csv")"
[ "$mode" = short ] || [ -f "$csv" ] || echo "date,target,engine,executions,seconds,coverage,features,findings,cpu_seconds,parser_edges" >"$csv"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
status=0
for t in $targets; do
  [ -z "${only:-}" ] || [ "$t" = "$only" ] || continue
  exe="$PWD/$build/fuzz/$t"
  engine=libfuzzer
  "$exe" -help=1 2>&1 | grep -q "ReplayDriver" && engine=replay
  case "$mode" in
    short)
      # Targets that run OpenCL kernels (vcz) or start a reader process (vdb) cost milliseconds per input.
      case "$t" in fuzz_vcz|fuzz_read_vdb) n=100 ;; *) n=500 ;; esac
      flags=(-runs="$n" -seed=1) ;;
    runs) n="$count"; flags=(-runs="$count") ;;
    seconds) n=0; flags=(-max_total_time="$count") ;;
  esac
  corpus=("$PWD/fuzz/corpus/$t")
  [ -d fuzz/regressions/"$t" ] && corpus+=("$PWD/fuzz/regressions/$t")
  if [ "$engine" = libfuzzer ]; then
    # A private copy of the seeds grows with what libFuzzer finds; the repository keeps the small seeds.
    grown="$work/$t"
    [ -z "${keep:-}" ] || grown="$keep/$t"
    mkdir -p "$grown" && cp -r fuzz/corpus/"$t"/. "$grown"/
    corpus=("$grown" "${corpus[@]:1}")
    # 500 MB: the limit every hostile input must stay under (inputs may claim 64 MiB, kFuzzMemoryBudget).
    # fuzz_vcz builds a kernel variant the first time an input asks for it (wavelet, brick size, voxel type),
    # and PoCL's LLVM then allocates through the sanitizer's allocator: about 260 MB more with its redzones
    # and 64 MB quarantine (the release CLI: +25 MB, 113 MB in all). On top of a long run's ~340 MB (corpus,
    # PoCL's built programs) that passed 500 MB. Its process limit is 1 GB; any single allocation of 500 MB
    # or more still stops the run, and the release CLI's bound is a test (CliHostile).
    rss=500; [ "$t" != fuzz_vcz ] || rss=1024
    flags+=(-timeout=2 -rss_limit_mb="$rss" -malloc_limit_mb=500 -max_len=65536 -print_final_stats=1)
  else
    flags+=(-timeout=2)
  fi
  opts="${ASAN_OPTIONS:-}"
  # AddressSanitizer keeps 256 MB of freed memory in quarantine by default, which with the process's own
  # ~70 MB left allocation-heavy targets (fuzz_series_pvd) at the 500 MB limit after millions of inputs
  # although each input alone stays near 50 MB (with no quarantine: 70 MB throughout). 64 MB is what one
  # input may claim (kFuzzMemoryBudget), so a use after free within an input is still caught.
  [ "$engine" = libfuzzer ] && case "$opts" in *quarantine_size_mb*) ;; *) opts="$opts:quarantine_size_mb=64" ;; esac
  case "$t" in
    # The fast unwinder stops in uninstrumented OpenImageIO, whose leaked per-thread error strings then miss
    # their suppression, and full unwinding on every malloc makes these targets 1000x slower (timeouts).
    # Long runs fuzz without leak checks and check leaks on the grown corpus afterwards, fully unwound
    # (the replay below); the short run unwinds fully throughout.
    fuzz_tf_png|fuzz_tf_exr)
      if [ "$mode" = short ]; then opts="$opts:fast_unwind_on_malloc=0"; else opts="$opts:detect_leaks=0"; fi ;;
  esac
  if [ "$t" = fuzz_vcz ] && [ "$engine" = libfuzzer ] && [ "$mode" != short ]; then
    # Every kernel variant an encoder's file can ask for is built first, in a process of its own (its
    # encodes leave an instrumented process near 1 GB), so no input pays a first build (FuzzVcz.cpp).
    mkdir -p "$work/none"
    if ! (cd "$work" && VOLCL_FUZZ_BUILD_ALL_KERNELS=1 ASAN_OPTIONS="${opts#:}" "$exe" -runs=0 "$work/none") \
      >"$work/kernels.log" 2>&1; then
      echo "fuzz_vcz: building the kernels failed:"; tail -20 "$work/kernels.log"; exit 1
    fi
  fi
  start=$(date +%s.%N)
  log="$work/$t.log"
  cpu="$work/$t.cpu"
  timer=(); [ -x /usr/bin/time ] && timer=(/usr/bin/time -o "$cpu" -f "%U %S")
  if (cd "$work" && ASAN_OPTIONS="${opts#:}" "${timer[@]}" "$exe" "${flags[@]}" "${corpus[@]}") >"$log" 2>&1; then
    findings=0
  else
    findings=1; status=1
  fi
  seconds=$(echo "$(date +%s.%N) - $start" | bc)
  # CPU seconds (user + system): on a shared machine wall time says little about a target's speed.
  cpus=""; [ -s "$cpu" ] && cpus=$(tail -1 "$cpu" | awk '{print $1 + $2}')
  execs=$(grep -o 'and [0-9]* mutated' "$log" | grep -o '[0-9]*' || true); cov=""; ft=""
  if [ "$engine" = libfuzzer ]; then
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1 || true)
    cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || true)
    ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || true)
  fi
  edges=""
  if [ "$engine" = libfuzzer ] && [ "$mode" != short ]; then
    # Edge coverage of the target's own parser files over the grown corpus (scripts/fuzz_coverage.py).
    replay="$opts"
    case "$t" in fuzz_tf_png|fuzz_tf_exr) replay="${replay/detect_leaks=0/detect_leaks=1}:fast_unwind_on_malloc=0" ;; esac
    if ! (cd "$work" && ASAN_OPTIONS="${replay#:}" "$exe" -runs=0 -print_coverage=1 -print_funcs=0 \
      -timeout=10 -rss_limit_mb="$rss" -malloc_limit_mb=500 "${corpus[@]}") >"$log.cov" 2>&1; then
      # The image targets' leak check happens here; for the others it repeats what the run checked.
      echo "  replay of the grown corpus failed:"; grep -E "ERROR|SUMMARY" "$log.cov" | head -5
      findings=1; status=1
    fi
    python3 scripts/fuzz_coverage.py "$t" <"$log.cov" | sed 's/^/  parser edges: /'
    # The format's own file (awk reads to the end: no broken pipe under pipefail).
    edges=$(python3 scripts/fuzz_coverage.py "$t" <"$log.cov" | awk 'NR == 1 {print $3}')
  fi
  printf '%-20s %-9s %10s execs %8.1f s (CPU %s s) cov %-6s ft %-6s %s\n' "$t" "$engine" "${execs:-?}" "$seconds" \
    "${cpus:-?}" "${cov:--}" "${ft:--}" "$([ $findings = 0 ] && echo ok || echo FINDING)"
  if [ $findings != 0 ]; then
    tail -40 "$log"
    cp "$work"/crash-* "$work"/timeout-* "$work"/leak-* "$work"/oom-* . 2>/dev/null || true
  fi
  [ "$mode" = short ] || echo "$(date -u +%FT%TZ),$t,$engine,${execs:-},$seconds,${cov:-},${ft:-},$findings,$cpus,$edges" >>"$csv"
done
exit $status
