"""docs/python-api.md is what python/api_reference.py writes from the installed package's docstrings."""
from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_api_reference_is_current():
    spec = importlib.util.spec_from_file_location("api_reference", ROOT / "python" / "api_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    committed = (ROOT / "docs" / "python-api.md").read_text()
    assert module.reference() == committed, "run build/venv/bin/python python/api_reference.py"
