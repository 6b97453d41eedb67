#!/usr/bin/env python3
"""Checks the reference pages: every relative link in README.md, docs/*.md and bench/results/**/*.md points
at a file or folder inside the repository, and docs/ holds no measurement logs (*.log: they belong under
bench/results/), and every ```json block in README.md and docs/ parses as JSON (readers copy them into
scene files). Prints each problem and exits 1.

Usage: scripts/check_doc_links.py [SOURCE_DIR]
"""
import json
import re
import sys
from pathlib import Path

LINK = re.compile(r"\]\(([^)\s]+)\)")
FENCE = re.compile(r"```.*?```", re.S)
JSON_BLOCK = re.compile(r"^```json[ \t]*\n(.*?)^```", re.S | re.M)


def json_block_problems(page, where):
    """One line per ```json block of `page` that is not valid JSON (comments, fragments, trailing commas)."""
    text = page.read_text(encoding="utf-8")
    problems = []
    for match in JSON_BLOCK.finditer(text):
        line = text.count("\n", 0, match.start()) + 1
        try:
            json.loads(match.group(1))
        except json.JSONDecodeError as e:
            problems.append(f"{where}:{line}: ```json block is not valid JSON: {e}")
    return problems


def main():
    root = Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).resolve().parent.parent).resolve()
    pages = [root / "README.md", *sorted((root / "docs").glob("*.md")),
             *sorted((root / "bench" / "results").rglob("*.md"))]
    problems = []
    for page in pages:
        text = FENCE.sub("", page.read_text(encoding="utf-8"))
        for match in LINK.finditer(text):
            target = match.group(1).split("#", 1)[0]
            if not target or re.match(r"[a-z][a-z0-9+.-]*:", target):  # in-page anchor, URL, mailto
                continue
            path = (page.parent / target).resolve()
            where = page.relative_to(root)
            if root not in path.parents and path != root:
                problems.append(f"{where}: link outside the repository: {match.group(1)}")
            elif not path.exists():
                problems.append(f"{where}: broken link: {match.group(1)}")
    for page in [root / "README.md", *sorted((root / "docs").rglob("*.md"))]:
        problems += json_block_problems(page, page.relative_to(root))
    for log in sorted((root / "docs").rglob("*.log")):
        problems.append(f"{log.relative_to(root)}: a measurement log under docs/ (move it to bench/results/)")
    for p in problems:
        print(p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
