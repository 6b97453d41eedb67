#!/usr/bin/env python3
"""Checks the library's floor plan: the folders named below include each other only downwards, so the
include graph between top-level folders has no cycle. Prints each offending include and exits 1.

Usage: scripts/check_layers.py [SOURCE_DIR]
"""
import re
import sys
from pathlib import Path

# Each folder and the folders it may include (besides itself). Everything outside the library (tests/,
# fuzz/, python/, plugins/, bench/) stands on top and is not listed: no library folder may include it.
ALLOWED = {
    "cl": set(),
    "core": {"cl"},
    "host": {"core", "cl"},
    "wavelet": {"core", "cl"},
    "meshcodec": {"wavelet", "host", "core", "cl"},
    "preintegration": {"host", "core", "cl"},
    "render": {"meshcodec", "wavelet", "preintegration", "host", "core", "cl"},
    "apps": {"render", "meshcodec", "wavelet", "preintegration", "host", "core", "cl"},
}
OUTSIDE = {"tests", "fuzz", "python", "plugins", "bench", "docs", "scripts"}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
SOURCES = {".cpp", ".hpp", ".h", ".c", ".cl", ".inc"}


def find_cycle(edges):
    """A cycle in the folder graph as a list of folders, or None."""
    state = {}

    def visit(node, path):
        state[node] = 1
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state:
                found = visit(nxt, path + [nxt])
                if found:
                    return found
        state[node] = 2
        return None

    for node in sorted(edges):
        if node not in state:
            found = visit(node, [node])
            if found:
                return found
    return None


def main():
    root = Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).resolve().parent.parent)
    edges, bad = {}, []
    for folder in ALLOWED:
        for path in sorted((root / folder).rglob("*")):
            if path.suffix not in SOURCES or not path.is_file():
                continue
            for target in INCLUDE.findall(path.read_text(encoding="utf-8", errors="replace")):
                top = target.split("/", 1)[0]
                if "/" not in target or (top not in ALLOWED and top not in OUTSIDE) or top == folder:
                    continue  # a kernel's own relative include, or a system-style name
                edges.setdefault(folder, set()).add(top)
                if top not in ALLOWED[folder]:
                    bad.append(f"{path.relative_to(root)}: includes {target} ({folder}/ may include only "
                               f"{', '.join(sorted(ALLOWED[folder])) or 'itself'})")
    cycle = find_cycle(edges)
    for line in bad:
        print(line)
    if cycle:
        print("include cycle between top-level folders: " + " -> ".join(cycle))
    if bad or cycle:
        return 1
    print("layers: " + "; ".join(f"{f} -> {', '.join(sorted(edges.get(f, ()))) or '-'}" for f in ALLOWED))
    return 0


if __name__ == "__main__":
    sys.exit(main())
