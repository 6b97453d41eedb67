"""``python -m volcl ARGS`` and the ``volcl`` console script run the volcl command line itself (the executable
installed with the package)."""
from __future__ import annotations

import os
import sys
from typing import List, Optional


def executable() -> str:
    """Path of the volcl executable installed beside this package (volcl/bin/volcl)."""
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "bin", "volcl")


def main(argv: Optional[List[str]] = None) -> None:
    """Replaces this process with ``volcl ARGS``: same output, same exit codes, same signals."""
    args = sys.argv[1:] if argv is None else argv
    exe = executable()
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(exe, [exe] + list(args))


if __name__ == "__main__":
    main()
