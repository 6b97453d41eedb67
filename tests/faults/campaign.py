#!/usr/bin/env python3
"""Fault-injection campaign: every volcl writer under full disks, SIGKILL/SIGTERM and concurrent writers.

For each writer (a CLI command and output format, or Python volcl.write) and each trial the target must
end as the old complete output (or nothing when none existed) or the new complete output, never anything
else, with no temporary left (after a kill, a temporary the next write removes is counted as "recovered");
a failed run exits 1 with one stderr line naming the output. A series pattern output killed during its
moves leaves a commit journal that volcl itself completes before any command reads or writes a frame;
the campaign runs that step (`volcl info` of frame 0) before judging such a trial, also "recovered".

  campaign.py --volcl build/volcl --shim build/tests/faults/libvolcl_fail_io.so --work DIR
              [--long] [--kills N] [--seed S] [--only REGEX] [--python PY]

Faults: (a) full disk: the LD_PRELOAD shim (fail_io.c) fails the Nth write/fsync/close/rename/link call on
the output directory (N = 1..count in --long, else the first and the last), and, where a mount namespace
can be made, a tmpfs too small for the new output; (b) SIGKILL and SIGTERM at seeded random moments of the
command (calibrated to its duration); (c) four concurrent writers of one target. The exit status is 1 when
any trial ends in a forbidden state; the summary counts trials and failures by kind per writer.
"""
import argparse
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import time
from collections import Counter, defaultdict
from pathlib import Path

# Call families of the shim, each failed with the errno a real file system gives there. Writes stay
# failed from the Nth on (a full disk stays full); the others fail once.
FAMILIES = [("write", "ENOSPC", True), ("fsync", "EIO", False), ("close", "EIO", False),
            ("rename", "EDQUOT", False), ("link", "ENOSPC", False)]
TEMP_NAME = re.compile(r"^\..*\.tmp-|\.tmp-\d|^\..*\.volcl-commit$")
# A series commit's journal (AtomicCommitGroup): left by a kill, any volcl command touching the series
# completes it.
JOURNAL_NAME = re.compile(r"^\..*\.volcl-commit$")
# A detached header's data file under a name unique to one write (NAME.<16 hex>.raw): while no header
# names it, it is a temporary like the hidden ones.
UNIQUE_DATA = re.compile(r"\.[0-9a-f]{16}\.[A-Za-z0-9.]+$")
UUID = re.compile(rb"[0-9a-f]{8}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{12}")
EXR_DATE = re.compile(rb"capDate\x00string\x00(....)", re.S)
VARIANTS = 4  # inputs per writer: old, new and (long form) two more for the concurrent rounds


def normalised(name, data):
    """Bytes that legitimately differ between two runs of one command are blanked: OpenVDB's grid UUIDs
    and the capture date OpenImageIO puts into EXR headers."""
    if name.endswith(".vdb"):
        data = UUID.sub(b"0" * 36, data)
    if name.endswith(".exr"):
        m = EXR_DATE.search(data)
        if m:
            n = int.from_bytes(m.group(1), "little")
            data = data[:m.end()] + b"\0" * n + data[m.end() + n:]
    return data


def header_data_files(name, text):
    """Data files a detached header names (NRRD "data file:", MetaImage "ElementDataFile"); the campaign
    reads them itself, so a header over the wrong data is seen as such."""
    files = []
    for line in text.splitlines():
        m = re.match(r"(data ?file|ElementDataFile)\s*[:=]\s*(.*)$", line)
        if m and m.group(2).strip() not in ("LOCAL", "LIST"):
            files.append(m.group(2).strip())
    return files


def snapshot(directory):
    """The output directory as a reader sees it: {name: bytes} with each detached header merged with the
    data it names, plus the temporaries and any data file no header names (both forbidden leftovers)."""
    names = sorted(os.listdir(directory))
    temps = [n for n in names if TEMP_NAME.search(n)]
    state, named = {}, set()
    for n in names:
        if n in temps or not (n.endswith(".nhdr") or n.endswith(".mhd")):
            continue
        raw = (Path(directory) / n).read_bytes()
        text = raw.decode("latin-1")
        blob = [raw]
        for f in header_data_files(n, text):
            named.add(f)
            p = Path(directory) / f
            blob.append(p.read_bytes() if p.is_file() else b"<missing " + f.encode() + b">")
        # The data file's name may be unique per write; the header minus that line is what must match.
        head = re.sub(rb"(?m)^(data ?file|ElementDataFile)\s*[:=].*$", b"", raw)
        state[n] = head + b"\0" + b"".join(blob[1:])
    for n in names:
        if n in temps or n in state or n in named:
            continue
        if UNIQUE_DATA.search(n):
            temps.append(n)
            continue
        state[n] = normalised(n, (Path(directory) / n).read_bytes())
    return state, temps


def classify(state, old, new):
    if state == new:
        return "new"
    if state == old:
        return "old"
    if not state and old:
        return "lost"
    if not old:
        return "partial"  # part of a new output set (a series' first frames, a data file without header)
    keys = set(state) | set(old) | set(new)
    parts = {"old" if state.get(k) == old.get(k) else "new" if state.get(k) == new.get(k) else "other"
             for k in keys}
    return "mixed" if parts == {"old", "new"} else "partial"


class Writer:
    """One writer: argv(variant) builds the command writing `target` (a name or printf pattern) in cwd."""

    def __init__(self, name, target, argv=None, python=None, per_file=False, long_only=False):
        self.name, self.target, self.argv_of, self.python = name, target, argv, python
        self.long_only = long_only  # slow (seconds a run): long form only
        # A command with several independent outputs (demo): each file old or new on its own.
        self.per_file = per_file
        self.refs = []  # snapshot of each variant's output, written alone in a clean directory
        self.ref_dirs = []
        self.calls = Counter()  # calls per shim family on the output directory, from the calibration run
        self.seconds = 0.0

    def command(self, ctx, variant):
        if self.python:
            return [ctx.python, "-c", self.python.format(inp=ctx.inputs, v=variant, out=self.target)]
        out = ["-o", self.target] if self.target else []
        return [ctx.volcl, "-q"] + self.argv_of(ctx.inputs, variant) + out


def writers(ctx):
    i = ctx.inputs
    w = []
    vol = lambda v: [f"{i}/in_{v}.nrrd"]  # noqa: E731
    for ext in [".raw", ".raw.gz", ".nrrd", ".nhdr", ".nii", ".nii.gz", ".vti", ".vdb"]:
        w.append(Writer(f"convert{ext}", "out" + ext, lambda i, v: ["convert"] + vol(v)))
    series = lambda i, v: ["convert", f"{i}/series_{v}.nii.gz"]  # noqa: E731
    w.append(Writer("convert-series.nii", "out.nii", series))
    w.append(Writer("convert-series.nrrd", "out.nrrd", series))
    w.append(Writer("convert-series-pattern.nrrd", "out_%02d.nrrd", series))
    w.append(Writer("convert-mesh.vtu", "out.vtu", lambda i, v: ["convert", f"{i}/mesh_{v}.vtk"]))
    w.append(Writer("encode.vcz", "out.vcz", lambda i, v: ["encode"] + vol(v)))
    w.append(Writer("encode-series.vcz", "out.vcz", lambda i, v: ["encode", f"{i}/series_{v}.nii.gz"]))
    w.append(Writer("decode.nhdr", "out.nhdr", lambda i, v: ["decode", f"{i}/enc_{v}.vcz"]))
    w.append(Writer("decode-series.nii.gz", "out.nii.gz", lambda i, v: ["decode", f"{i}/series_{v}.vcz"]))
    w.append(Writer("decode-series-pattern.nii", "out_%02d.nii", lambda i, v: ["decode", f"{i}/series_{v}.vcz"]))
    # Skipping on: auto measures its choice per run and the EXR records the kernel that ran, so a reference
    # run and a faulted run could differ in that attribute alone.
    render = lambda i, v: ["render", "--volume", f"{i}/in_{v}.nrrd", "--tf", "preset:viridis",  # noqa: E731
                           "--width", "48", "--height", "40", "--skipping", "on"]
    w.append(Writer("render.png", "out.png", render))
    w.append(Writer("render.exr", "out.exr", render))
    w.append(Writer("render-iso.exr", "out.exr", lambda i, v: render(i, v) + ["--mode", "iso", "--iso", "60"]))
    presets = ["viridis", "inferno", "plasma", "grayscale"]
    w.append(Writer("preint.exr", "out.exr", lambda i, v: ["preint", "--tf", f"preset:{presets[v]}", "--step",
                                                           "0.5", "--size", "64"]))
    gen = lambda i, v: ["generate", "cloud", "--size", "24,20,16", "--seed", str(11 + v)]  # noqa: E731
    w.append(Writer("generate.nrrd", "out.nrrd", gen))
    w.append(Writer("generate.vcz", "out.vcz", gen))
    w.append(Writer("demo", "", lambda i, v: ["demo", "-o", ".", "--ml-size", str(5 + v), "--phantom-size", "12"],
                    per_file=True, long_only=True))
    if ctx.python:
        for ext in [".nhdr", ".nii.gz", ".vdb"]:
            w.append(Writer(f"python-write{ext}", "out" + ext, python=(
                "import sys, numpy as np, volcl\n"
                "a = np.arange(16*20*24, dtype=np.float32).reshape(16, 20, 24) * {v} + {v}\n"
                "try:\n"
                "    volcl.write('{out}', a)\n"
                "except volcl.IoError as e:\n"  # the one error class a write failure may raise
                "    sys.exit('IoError: ' + str(e))\n")))
    return [x for x in w if (not ctx.only or re.search(ctx.only, x.name)) and (ctx.long or not x.long_only)]


class Context:
    def __init__(self, args):
        self.volcl = str(Path(args.volcl).resolve())
        self.shim = str(Path(args.shim).resolve())
        self.work = Path(args.work).resolve()
        self.inputs = str(self.work / "inputs")
        self.python = os.path.abspath(args.python) if args.python else None  # not resolved: a venv's python is a link
        self.only = args.only
        self.long = args.long
        self.variants = VARIANTS if args.long else 2  # the short form's concurrent writers alternate two inputs
        self.rng = random.Random(args.seed)
        self.trial_id = 0
        self.results = defaultdict(Counter)  # writer -> Counter(kind)
        self.failures = []
        self.namespace = None  # argv prefix that gives a private mount namespace, when one can be made

    def env(self, **extra):
        e = dict(os.environ)
        e.pop("LD_PRELOAD", None)
        e.update(extra)
        return e

    def fresh_dir(self):
        self.trial_id += 1
        d = self.work / "trials" / str(self.trial_id)
        shutil.rmtree(d, ignore_errors=True)
        d.mkdir(parents=True)
        return d


def run(cmd, cwd, env, timeout=300):
    return subprocess.run(cmd, cwd=cwd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          timeout=timeout)


def make_inputs(ctx):
    d = Path(ctx.inputs)
    shutil.rmtree(ctx.work, ignore_errors=True)
    d.mkdir(parents=True)
    v = [ctx.volcl, "-q"]

    def must(cmd):
        p = subprocess.run(cmd, cwd=d, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        if p.returncode != 0:
            sys.exit(f"campaign: setup failed: {' '.join(cmd)}: {p.stderr.decode().strip()}")

    for k in range(VARIANTS):
        must(v + ["generate", "cloud", "-o", f"in_{k}.nrrd", "--size", "24,20,16", "--seed", str(3 + k)])
        for f in range(3):
            must(v + ["generate", "cloud", "-o", f"frame_{k}_{f}.nrrd", "--size", "16,16,8", "--seed",
                      str(100 + 10 * k + f)])
        must(v + ["encode", f"frame_{k}_*.nrrd", "-o", f"series_{k}.vcz"])
        must(v + ["decode", f"series_{k}.vcz", "-o", f"series_{k}.nii.gz"])
        must(v + ["encode", f"in_{k}.nrrd", "-o", f"enc_{k}.vcz"])
        # Two tetrahedra, their point values scaled by the variant.
        (d / f"mesh_{k}.vtk").write_text(
            "# vtk DataFile Version 3.0\ntets\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 5 float\n"
            "0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\nCELLS 2 10\n4 0 1 2 3\n4 1 2 3 4\nCELL_TYPES 2\n10\n10\n"
            "POINT_DATA 5\nSCALARS s float 1\nLOOKUP_TABLE default\n" +
            " ".join(str((k + 1) * x) for x in range(5)) + "\n")


def reference(ctx, w):
    """Each variant's output written alone in a clean directory, kept as the old file trials start from."""
    for k in range(ctx.variants):
        d = ctx.work / "refs" / w.name.replace("%", "") / str(k)
        shutil.rmtree(d, ignore_errors=True)
        d.mkdir(parents=True)
        t0 = time.monotonic()
        p = run(w.command(ctx, k), d, ctx.env())
        w.seconds = max(w.seconds, time.monotonic() - t0)
        if p.returncode != 0:  # a writer that fails with no fault at all: reported, its trials skipped
            record(ctx, w, "reference", f"variant {k}", f"reference-failed ({p.stderr.decode().strip()[:160]})")
            return False
        state, temps = snapshot(d)
        if temps or not state:
            sys.exit(f"campaign: {w.name}: reference run left {temps or 'no output'}")
        w.refs.append(state)
        w.ref_dirs.append(d)
    if len({repr(sorted(r.items())) for r in w.refs}) != ctx.variants:
        sys.exit(f"campaign: {w.name}: the variants' outputs are not all different")
    return True


def seed_old(d, old_state_dir):
    for f in os.listdir(old_state_dir):
        shutil.copy2(old_state_dir / f, d / f)


def names_output(stderr, target):
    lines = stderr.decode(errors="replace").strip().splitlines()
    stem = target.split("%")[0].split(".")[0] or "/"  # demo: any output of its directory
    return len(lines) == 1 and stem in lines[0]


def short_kind(kind):
    return kind.split(" (")[0].split(" ")[0]


def record(ctx, w, mode, detail, kind):
    ctx.results[w.name]["trials"] += 1
    if kind in ("new", "old", "recovered"):
        ctx.results[w.name][kind] += 1
    else:
        ctx.results[w.name]["kind:" + short_kind(kind)] += 1
        ctx.failures.append(f"{w.name} {mode} {detail}: {kind}")


def judge(ctx, w, mode, detail, d, returncode, stderr, old, new, killed=False):
    state, temps = snapshot(d)
    journal_recovered = False
    if killed and "%" in w.target and any(JOURNAL_NAME.search(t) for t in temps):
        # The guarantee for a killed series commit is "a volcl reader never sees a mixed series": the next
        # volcl command that reads (or writes) a frame rolls the journal forward first. Run that step, as
        # any later volcl use of the series would, and judge what it leaves.
        run([ctx.volcl, "-q", "info", w.target % 0], d, ctx.env())
        state, temps = snapshot(d)
        journal_recovered = True
    outcome = classify(state, old, new)
    if w.per_file and all(state.get(k) in (old.get(k), new.get(k)) for k in set(state) | set(old) | set(new)):
        outcome = "new" if state == new else "old"  # each output old (or absent) or new on its own
    if temps:
        # Between the link that names a temporary and the rename over the target a kill cannot be cleaned
        # up after (Linux cannot link a file over another); AtomicFile's documented answer is that the
        # next write of the target removes a dead writer's temporary. So after a kill a temporary that the
        # next write removes, with the target old or new, is counted apart ("recovered"); any other
        # temporary fails the trial.
        p = run(w.command(ctx, 1), d, ctx.env())
        left = snapshot(d)[1] if p.returncode == 0 else temps
        if killed and not left and outcome in ("old", "new"):
            return record(ctx, w, mode, detail, "recovered")
        note = "removed by the next write" if not left else "still there after the next write"
        return record(ctx, w, mode, detail, f"stale-temporary ({','.join(temps)}, {note}, outcome {outcome})")
    if journal_recovered:
        return record(ctx, w, mode, detail, "recovered" if outcome in ("old", "new") else f"failed-{outcome}")
    if returncode == 0:
        return record(ctx, w, mode, detail, "new" if outcome == "new" else f"exit-0-{outcome}")
    if returncode < 0 and not (killed and -returncode in (signal.SIGKILL, signal.SIGTERM)):
        return record(ctx, w, mode, detail, f"crash-signal-{-returncode}")
    if outcome not in ("old", "new") or (outcome == "new" and not killed):
        return record(ctx, w, mode, detail, f"failed-{outcome}")
    if not killed and (returncode != 1 or not names_output(stderr, w.target)):
        msg = stderr.decode(errors="replace").strip().replace("\n", " | ")[:160]
        return record(ctx, w, mode, detail, f"message (exit {returncode}: {msg})")
    record(ctx, w, mode, detail, outcome)


def shim_trials(ctx, w):
    new = w.refs[1]
    d = ctx.fresh_dir()
    count_file = ctx.work / "count"
    count_file.unlink(missing_ok=True)
    env = ctx.env(LD_PRELOAD=ctx.shim, VOLCL_FAIL_DIR=str(d), VOLCL_FAIL_CALL="count", VOLCL_FAIL_AT="0",
                  VOLCL_FAIL_COUNT_FILE=str(count_file))
    p = run(w.command(ctx, 1), d, env)
    # The preloaded shim alone (no call failed) must leave the writer's output as it is without it.
    judge(ctx, w, "shim", "count only", d, p.returncode, p.stderr, {}, w.refs[1])
    counts = Counter()
    for line in count_file.read_text().splitlines() if count_file.exists() else []:
        family, n = line.split()
        counts[family] = max(counts[family], int(n))
    w.calls = counts
    for family, err, sticky in FAMILIES:
        calls = counts[family]
        if calls == 0:
            continue
        if not ctx.long:
            ns = sorted({1, calls})
        elif calls <= 24:
            ns = range(1, calls + 1)
        else:  # image libraries make hundreds of small writes: both ends and a seeded sample between
            ns = sorted(set(range(1, 5)) | set(range(calls - 3, calls + 1)) |
                        set(ctx.rng.sample(range(5, calls - 3), 16)))
        for n in ns:
            with_old = (n % 2 == 1)
            d = ctx.fresh_dir()
            if with_old:
                seed_old(d, w.ref_dirs[0])
            old = w.refs[0] if with_old else {}
            env = ctx.env(LD_PRELOAD=ctx.shim, VOLCL_FAIL_DIR=str(d), VOLCL_FAIL_CALL=family,
                          VOLCL_FAIL_AT=str(n), VOLCL_FAIL_ERRNO=err, VOLCL_FAIL_STICKY="1" if sticky else "0")
            p = run(w.command(ctx, 1), d, env)
            judge(ctx, w, "shim", f"{family}#{n}/{calls} {err}{' old' if with_old else ''}", d, p.returncode,
                  p.stderr, old, new)


def find_namespace(ctx):
    probe = ctx.work / "probe"
    probe.mkdir(exist_ok=True)
    for prefix in (["unshare", "--mount"], ["unshare", "--user", "--map-root-user", "--mount"]):
        try:
            p = subprocess.run(prefix + ["sh", "-c", f"mount -t tmpfs -o size=8k tmpfs '{probe}'"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=30)
        except (OSError, subprocess.TimeoutExpired):
            continue
        if p.returncode == 0:
            ctx.namespace = prefix
            return


def tmpfs_trials(ctx, w):
    """The command in a private mount namespace whose output directory is a tmpfs holding the old output
    and fewer pages than the new one needs; the directory is copied out for judging."""
    page = 4096
    old = w.ref_dirs[0]
    old_pages = sum((f.stat().st_size + page - 1) // page for f in old.iterdir())
    new_pages = sum((f.stat().st_size + page - 1) // page for f in w.ref_dirs[1].iterdir())
    extra = range(new_pages) if ctx.long else sorted({0, new_pages - 1})
    for k in list(extra)[:8]:
        size = (old_pages + k) * page
        mnt, snap = ctx.fresh_dir(), ctx.fresh_dir()
        rc_file, err_file = ctx.work / "tmpfs.rc", ctx.work / "tmpfs.err"
        script = ('mount -t tmpfs -o size="$1" tmpfs "$2" && cp -a "$3"/. "$2"/ && cd "$2" && shift 3 && '
                  '{ "$@" 2>"$FAULT_ERR"; echo $? > "$FAULT_RC"; cp -a . "$FAULT_SNAP"/; }')
        env = ctx.env(FAULT_ERR=str(err_file), FAULT_RC=str(rc_file), FAULT_SNAP=str(snap))
        rc_file.unlink(missing_ok=True)
        subprocess.run(ctx.namespace + ["sh", "-c", script, "sh", str(size), str(mnt), str(old)]
                       + w.command(ctx, 1),
                       env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=300)
        if not rc_file.exists():
            record(ctx, w, "tmpfs", f"{size} bytes", "tmpfs-setup-failed")
            continue
        rc = int(rc_file.read_text())
        judge(ctx, w, "tmpfs", f"{size} bytes", snap, rc, err_file.read_bytes(), w.refs[0], w.refs[1])


def kill_trials(ctx, w, n):
    """Even trials: a signal at a seeded moment of the run (calibrated to its duration, half of them near its
    end where the output is written). Odd trials: the shim sends the signal just before a seeded call of
    the write protocol (write, fsync, close, rename, link), so the commit's every step is reached."""
    points = [(f, k) for f, _, _ in FAMILIES for k in range(1, w.calls[f] + 1)]
    for t in range(n):
        sig = signal.SIGKILL if (t // 2) % 2 == 0 else signal.SIGTERM
        with_old = ctx.rng.random() < 0.5
        d = ctx.fresh_dir()
        if with_old:
            seed_old(d, w.ref_dirs[0])
        if t % 2 == 1 and points:
            family, k = ctx.rng.choice(points)
            env = ctx.env(LD_PRELOAD=ctx.shim, VOLCL_FAIL_DIR=str(d), VOLCL_FAIL_CALL=family, VOLCL_FAIL_AT=str(k),
                          VOLCL_FAIL_SIGNAL=sig.name[3:])
            p = run(w.command(ctx, 1), d, env)
            landed, err, where = p.returncode == -sig, p.stderr, f"before {family}#{k}"
            returncode = p.returncode
        else:
            span = w.seconds * 1.1
            delay = ctx.rng.uniform(0, span) if ctx.rng.random() < 0.5 else ctx.rng.uniform(0.7 * span, span)
            p = subprocess.Popen(w.command(ctx, 1), cwd=d, env=ctx.env(), stdout=subprocess.DEVNULL,
                                 stderr=subprocess.PIPE)
            time.sleep(delay)
            landed = p.poll() is None
            if landed:
                p.send_signal(sig)
            _, err = p.communicate(timeout=300)
            returncode, where = p.returncode, f"@{delay:.3f}s"
        ctx.results[w.name]["kills-landed"] += landed
        ctx.results[w.name]["kill-trials"] += 1
        judge(ctx, w, "kill", f"{sig.name} {where}{' old' if with_old else ''}", d, returncode, err,
              w.refs[0] if with_old else {}, w.refs[1], killed=True)


def concurrent_trials(ctx, w, rounds):
    for r in range(rounds):
        d = ctx.fresh_dir()
        procs = [subprocess.Popen(w.command(ctx, k % ctx.variants), cwd=d, env=ctx.env(),
                                  stdout=subprocess.DEVNULL, stderr=subprocess.PIPE) for k in range(4)]
        outs = [p.communicate(timeout=300)[1] for p in procs]
        state, temps = snapshot(d)
        bad = [f"exit {p.returncode}: {e.decode(errors='replace').strip()[:120]}" for p, e in zip(procs, outs)
               if p.returncode != 0]
        if temps:
            kind = "stale-temporary " + ",".join(temps)
        elif bad:
            kind = "writer-failed " + "; ".join(bad)
        elif any(state == ref for ref in w.refs):
            kind = "new"
        elif w.per_file and set(state) == set(w.refs[0]) and all(
                any(state[k] == ref[k] for ref in w.refs) for k in state):
            kind = "new"
        else:
            parts = {next((j for j, ref in enumerate(w.refs) if state.get(k) == ref.get(k)), None) for k in
                     set(state) | set(w.refs[0])}
            kind = "mixed" if None not in parts and len(parts) > 1 else "partial"
        record(ctx, w, "concurrent", f"round {r}", kind)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--volcl", required=True)
    ap.add_argument("--shim", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--python", help="interpreter that imports volcl: adds the Python writers")
    ap.add_argument("--long", action="store_true", help="every N of every call family, more kills and rounds")
    ap.add_argument("--kills", type=int, help="kill trials per writer (default 2, --long 10)")
    ap.add_argument("--rounds", type=int, help="concurrent rounds per writer (default 1, --long 5)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--only", help="regular expression: only writers whose name matches")
    args = ap.parse_args()
    ctx = Context(args)
    make_inputs(ctx)
    find_namespace(ctx)
    kills = args.kills if args.kills is not None else (10 if args.long else 2)
    rounds = args.rounds if args.rounds is not None else (5 if args.long else 1)
    print(f"fault campaign: {'long' if args.long else 'short'} form, seed {args.seed}, tmpfs "
          f"{'via ' + ' '.join(ctx.namespace) if ctx.namespace else 'unavailable (shim only)'}", flush=True)
    for w in writers(ctx):
        t0 = time.monotonic()
        if reference(ctx, w):
            shim_trials(ctx, w)
            if ctx.namespace:
                tmpfs_trials(ctx, w)
            kill_trials(ctx, w, kills)
            concurrent_trials(ctx, w, rounds)
        c = ctx.results[w.name]
        bad = c["trials"] - c["new"] - c["old"] - c["recovered"]
        kinds = ", ".join(f"{k[5:]} {n}" for k, n in sorted(c.items()) if k.startswith("kind:"))
        print(f"{w.name:28s} trials {c['trials']:4d}  new {c['new']:4d}  old {c['old']:4d}  recovered {c['recovered']:2d}  failed {bad:4d}"
              f"{' (' + kinds + ')' if kinds else ''}  kills landed {c['kills-landed']}/{c['kill-trials']}  "
              f"({time.monotonic() - t0:.1f} s)", flush=True)
        shutil.rmtree(ctx.work / "trials", ignore_errors=True)
        shutil.rmtree(ctx.work / "refs", ignore_errors=True)
    kinds = Counter()
    for f in ctx.failures:
        kinds[short_kind(f.split(": ", 1)[1])] += 1
    total = sum(c["trials"] for c in ctx.results.values())
    kill_total = sum(c["kills-landed"] for c in ctx.results.values())
    kill_trials_run = sum(c["kill-trials"] for c in ctx.results.values())
    print(f"total: {total} trials ({kill_trials_run} kill trials, {kill_total} landed before the command "
          f"ended), {len(ctx.failures)} failed "
          f"({', '.join(f'{k} {n}' for k, n in kinds.most_common()) or 'none'})")
    for f in ctx.failures:
        print("FAIL " + f)
    return 1 if ctx.failures else 0


if __name__ == "__main__":
    sys.exit(main())
