"""Output files that appear whole or not at all.

Every command checks its output paths before it computes anything (a missing folder or a directory in
place of a file is an OSError naming the path: exit 4), writes to a temporary file next to the target and
renames it at the end, so a failed run leaves nothing behind. An existing output that is not a regular file
(/dev/null, a FIFO) is written in place, as the C tools do.
"""
from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from pathlib import Path
from typing import Iterator, Union

PathLike = Union[str, Path]


def check_output_file(path: PathLike) -> Path:
    """`path` can be created: its folder exists and it is not a directory. Raises OSError (exit 4)."""
    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(f"{p}: is a directory, expected an output file name")
    parent = p.parent
    if not parent.is_dir():
        why = "not a directory" if parent.exists() else "No such file or directory"
        raise FileNotFoundError(f"{p}: cannot write: {why}: {parent}")
    if not os.access(parent, os.W_OK):
        raise PermissionError(f"{p}: cannot write: Permission denied")
    return p


def check_output_dir(path: PathLike) -> Path:
    """`path` is a directory or can be made one (nothing is created here). Raises OSError (exit 4)."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise NotADirectoryError(f"{p}: exists and is not a directory (an output folder is needed)")
    for a in p.parents:
        if a.exists():
            if not a.is_dir():
                raise NotADirectoryError(f"{p}: cannot create: {a} is not a directory")
            break
    return p


def _in_place(p: Path) -> bool:
    try:
        return not stat.S_ISREG(os.stat(p).st_mode)
    except FileNotFoundError:
        return False


@contextlib.contextmanager
def atomic_output(path: PathLike) -> Iterator[Path]:
    """Yields a temporary path next to `path`; renamed to `path` when the block ends without error,
    removed otherwise."""
    p = check_output_file(path)
    if _in_place(p):
        yield p
        return
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp" + p.suffix, dir=p.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # what open() would have made, not mkstemp's 0600
    try:
        yield Path(tmp)
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def write_text_atomic(path: PathLike, text: str) -> None:
    with atomic_output(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
