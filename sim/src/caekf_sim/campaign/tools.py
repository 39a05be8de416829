"""Where the C host tools are: $CAEKF_BUILD_DIR/host, else build/host-double/host of this tree."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Optional

REPO = Path(__file__).resolve().parents[4]


def build_dir() -> Path:
    env = os.environ.get("CAEKF_BUILD_DIR")
    return Path(env) if env else REPO / "build" / "host-double"


def c_tool(name: str) -> Optional[Path]:
    """Path of a C host tool (caekf-truth, caekf-replay) or None when not built."""
    p = build_dir() / "host" / name
    return p if p.is_file() and os.access(p, os.X_OK) else None


def require_tool(name: str) -> Path:
    p = c_tool(name)
    if p is None:
        raise RuntimeError(f"{name} not found in {build_dir() / 'host'} (build host-double or set CAEKF_BUILD_DIR)")
    return p
