#!/usr/bin/env python3
"""Status of every libFuzzer target from bench/results/reliability/fuzz-runs.csv, as the table in docs/reliability.md.

  scripts/fuzz_status.py            print the table
  scripts/fuzz_status.py --write    replace the table between the fuzz-status markers in docs/reliability.md

Per target: libFuzzer executions summed over every run, the coverage (cov / ft) and parser edges of the
latest run, the speed of the latest run that recorded CPU time (executions per CPU second, start-up
included), the runs that ended on a finding, and what 10^7 executions in all still need at that speed on
one core. A target counts as done once its total reaches 10^7 and its latest run ended clean (every
finding on the way was fixed before the runs after it).
"""
import csv
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
CSV = ROOT / "bench" / "results" / "reliability" / "fuzz-runs.csv"
DOC = ROOT / "docs" / "reliability.md"
BEGIN = "<!-- fuzz-status:begin (scripts/fuzz_status.py --write) -->"
END = "<!-- fuzz-status:end -->"
GOAL = 10_000_000


def duration(seconds):
    if seconds >= 3600:
        return f"{seconds / 3600:.1f} h"
    return f"{max(1, round(seconds / 60))} min"


def table():
    targets = {}
    for row in csv.DictReader(CSV.open()):
        if row["engine"] != "libfuzzer" or not row["executions"]:
            continue
        t = targets.setdefault(row["target"], {"execs": 0, "findings": 0, "speed": None})
        t["execs"] += int(row["executions"])
        t["findings"] += int(row["findings"] or 0)
        t["last"] = row
        # CPU time where the run recorded it; otherwise wall time, a lower bound of the speed (an interrupted
        # run's children, such as fuzz_read_vdb's reader service, are not in its CPU time).
        if row["cpu_seconds"] and float(row["cpu_seconds"]) > 0:
            t["speed"], t["wall"] = int(row["executions"]) / float(row["cpu_seconds"]), False
        elif row["seconds"] and float(row["seconds"]) > 0:
            t["speed"], t["wall"] = int(row["executions"]) / float(row["seconds"]), True
    lines = [
        "| Target | libFuzzer executions in all runs | runs ended by a finding (all fixed) | cov / ft (latest run) "
        "| parser edges (latest run) | executions per CPU s (latest run) | time still needed for 10^7 on one core |",
        "|---|---|---|---|---|---|---|",
    ]
    done = []
    for name in sorted(targets):
        t = targets[name]
        last = t["last"]
        reached = t["execs"] >= GOAL and last["findings"] == "0"
        if reached:
            done.append(name)
        speed = (f"{t['speed']:,.0f}" + (" (wall)" if t["wall"] else "")) if t["speed"] else "-"
        if reached:
            need = "-"
        elif t["speed"]:
            need = duration((GOAL - t["execs"]) / t["speed"])
        else:
            need = "unknown"
        execs = f"**{t['execs']:,}**" if reached else f"{t['execs']:,}"
        lines.append(f"| {name} | {execs} | {t['findings']} | {last['coverage']} / {last['features']} "
                     f"| {last['parser_edges'] or '-'} | {speed} | {need} |")
    lines.append("")
    lines.append(f"{len(done)} of {len(targets)} targets have run 10^7 executions or more in all, their latest "
                 "run clean.")
    return "\n".join(lines)


def main():
    text = table()
    if sys.argv[1:] == ["--write"]:
        doc = DOC.read_text()
        if BEGIN not in doc or END not in doc:
            sys.exit(f"{DOC}: the fuzz-status markers are missing")
        head, rest = doc.split(BEGIN, 1)
        _, tail = rest.split(END, 1)
        DOC.write_text(head + BEGIN + "\n" + text + "\n" + END + tail)
    elif sys.argv[1:]:
        sys.exit("usage: scripts/fuzz_status.py [--write]")
    else:
        print(text)


if __name__ == "__main__":
    main()
