#!/bin/sh
# Byte identity of two volcl builds: encodes every data set with every rate mode and entropy coder with
# both, compares the .vcz files, then decodes each file with both builds and compares the voxels (so old
# files are also shown to decode the same with the new build).
# Usage: bench/codec_identity.sh OLD_VOLCL NEW_VOLCL [DATA_DIR] [WORK_DIR] [NAMES]
# NAMES: a space-separated subset of the data set names below (default all). An encoding that both builds
# refuse counts as identical when the two messages are.
# (OLD_VOLCL / NEW_VOLCL are commands, e.g. a wrapper setting LD_LIBRARY_PATH for a copied build.)
set -eu
old=$1
new=$2
data=${3:-$(dirname "$0")/../../shared/data}
work=${4:-$(mktemp -d)}
names=${5:-}
mkdir -p "$work"
same=0
differ=0
compare() { # label file-a file-b
    if cmp -s "$2" "$3"; then same=$((same + 1)); else differ=$((differ + 1)); echo "DIFFER $1"; fi
}
run() { # name input mode-args...
    name=$1
    input=$2
    shift 2
    tag=$(echo "$name $*" | tr ' ,.' '___')
    if ! $old encode "$input" -o "$work/$tag.old.vcz" "$@" 2>"$work/$tag.old.err"; then
        if $new encode "$input" -o "$work/$tag.new.vcz" "$@" 2>"$work/$tag.new.err"; then
            differ=$((differ + 1))
            echo "DIFFER $name $*: only the old build refuses"
        else
            compare "$name $* (refusal)" "$work/$tag.old.err" "$work/$tag.new.err"
        fi
        rm -f "$work/$tag".*
        return
    fi
    $new encode "$input" -o "$work/$tag.new.vcz" "$@" 2>/dev/null
    compare "$name $* (.vcz)" "$work/$tag.old.vcz" "$work/$tag.new.vcz"
    $old decode "$work/$tag.old.vcz" -o "$work/$tag.old.raw" 2>/dev/null
    $new decode "$work/$tag.old.vcz" -o "$work/$tag.new.raw" 2>/dev/null
    compare "$name $* (decoded)" "$work/$tag.old.raw" "$work/$tag.new.raw"
    rm -f "$work/$tag".*
}
for set in \
    "brainweb $data/regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz" \
    "walnut $data/regular/walnut.vvd" \
    "hydrogen $data/regular/hydrogenatom.dat" \
    "nucleon $data/regular/nucleon.nrrd" \
    "headmr $data/regular/HeadMRVolume.mhd" \
    "smoke $data/vdb/smoke.vdb" \
    "fmri $data/timevarying/functional.nii.gz" \
    "ch2better /usr/share/mricron/templates/ch2better.nii.gz"; do
    set -- $set
    name=$1
    input=$2
    case " ${names:-$name} " in *" $name "*) ;; *) continue ;; esac
    [ -e "$input" ] || { echo "skip $name: $input missing"; continue; }
    for coder in dense fast; do
        run "$name" "$input" --entropy $coder --lossless
        run "$name" "$input" --entropy $coder --max-error 2
        run "$name" "$input" --entropy $coder --max-error 0.5
        run "$name" "$input" --entropy $coder --psnr 45
        run "$name" "$input" --entropy $coder --bpv 1
        run "$name" "$input" --entropy $coder --psnr 40 --step 3
    done
    run "$name" "$input" --wavelet haar --levels 3 --brick 32
done
echo "identical: $same, different: $differ"
[ "$differ" -eq 0 ]
