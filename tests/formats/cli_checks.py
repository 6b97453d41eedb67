"""Helpers the CLI format scripts share: command-line arguments, running volcl, and counted checks."""
import subprocess
import sys

VOLCL, WORK = sys.argv[1], sys.argv[2]
SHARED = sys.argv[3] if len(sys.argv) > 3 else ""
failures = []


def run(*args):
    """volcl --quiet ARGS, its exit code and output kept (for refusals)."""
    return subprocess.run([VOLCL, "--quiet", *args], capture_output=True, text=True)


def volcl(*args):
    """volcl --quiet ARGS, which must succeed; returns its standard output."""
    r = run(*args)
    if r.returncode != 0:
        raise SystemExit(f"volcl {' '.join(args)} failed ({r.returncode}): {r.stderr.strip()}")
    return r.stdout


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        failures.append(what)


def finish():
    """Exit 1 when any check failed."""
    if failures:
        print(f"{len(failures)} check(s) failed")
        sys.exit(1)
