#!/usr/bin/env python3
"""Writes docs/python-api.md, the API reference of the volcl package, from its signatures and docstrings.

Usage: build/venv/bin/python python/api_reference.py [OUTPUT]  (default docs/python-api.md; "-" prints it).
python/tests/test_api_reference.py checks that the committed file matches what this script writes.
"""
from __future__ import annotations

import importlib
import inspect
import sys
from pathlib import Path

# Document the installed package, not the sources beside this script (they lack the compiled module).
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]
import volcl  # noqa: E402
import volcl.numcodecs  # noqa: E402

HEADER = """# volcl Python API reference

Generated from the package's signatures and docstrings by `python/api_reference.py` (the tests check it
is current); `help(volcl.NAME)` shows the same text. The tour is in [python.md](python.md).
"""


def annotation(a) -> str:
    return a if isinstance(a, str) else inspect.formatannotation(a)


# Reading order: files, the codec, transfer functions and tables, rendering, devices.
ORDER = ["read", "write", "Volume", "encode", "decode", "VczFile", "VczFrame", "TransferFunction", "TF",
         "preintegration_table", "render", "composite", "read_image", "devices"]


def signature(obj) -> str:
    """The signature as written in the source (annotations unquoted), private parameters left out."""
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return "(...)"
    parts, star_done = [], False
    for p in sig.parameters.values():
        if p.name.startswith("_"):
            continue
        if p.kind == p.KEYWORD_ONLY and not star_done:
            parts.append("*")
            star_done = True
        text = p.name
        if p.annotation is not p.empty:
            text += ": " + annotation(p.annotation)
        if p.default is not p.empty:
            text += (" = " if p.annotation is not p.empty else "=") + repr(p.default)
        parts.append(text)
    out = "(" + ", ".join(parts) + ")"
    if sig.return_annotation is not sig.empty:
        out += " -> " + annotation(sig.return_annotation).strip("'\"")
    return out.replace("'os.PathLike[str]'", "os.PathLike[str]").replace("\"Optional['_volcl.TransferFunction']\"", "")


def doc(obj) -> str:
    return inspect.getdoc(obj) or ""


def document_class(name: str, cls) -> list:
    out = [f"## class `{name}{signature(cls)}`", "", doc(cls), ""]
    for member, value in sorted(vars(cls).items()):
        if member.startswith("_"):
            continue
        if isinstance(value, property):
            out += [f"- property `{member}`" + (f": {doc(value)}" if doc(value) else ""), ""]
        elif isinstance(value, (classmethod, staticmethod)):
            fn = value.__func__
            out += [f"### `{name}.{member}{signature(getattr(cls, member))}`", "", doc(fn), ""]
        elif inspect.isfunction(value):
            out += [f"### `{name}.{member}{signature(value)}`", "", doc(value), ""]
    return out


def reference() -> str:
    lines = [HEADER]
    for name in ORDER:
        obj = getattr(volcl, name)
        if name == "TF":
            lines += ["## `TF`", "", "Short name of `TransferFunction`.", ""]
        elif inspect.isclass(obj):
            lines += document_class(name, obj)
        else:
            lines += [f"## `{name}{signature(obj)}`", "", doc(obj), ""]
    lines += ["## Exceptions", ""]
    for name in ("Error", "UsageError", "IoError", "DataError", "ClError"):
        exc = getattr(volcl, name)
        lines += [f"- `{name}` ({exc.__mro__[1].__name__}): {doc(exc)}"]
    lines += [""]
    lines += document_class("volcl.numcodecs.Volcl", volcl.numcodecs.Volcl)
    lines += ["## `python -m volcl ARGS`", "", doc(importlib.import_module("volcl.__main__")), ""]
    text = "\n".join(lines)
    return "\n".join(line.rstrip() for line in text.splitlines()).rstrip() + "\n"


def main() -> int:
    target = sys.argv[1] if len(sys.argv) > 1 else str(Path(__file__).resolve().parents[1] / "docs" / "python-api.md")
    text = reference()
    if target == "-":
        sys.stdout.write(text)
    else:
        Path(target).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
