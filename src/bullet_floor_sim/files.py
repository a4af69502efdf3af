"""Files written whole or not at all."""
from __future__ import annotations

import contextlib
import os
import tempfile
from typing import IO, Iterator

__all__ = ["atomic_file"]


@contextlib.contextmanager
def atomic_file(path: str, mode: str = "w", fsync: bool = True) -> Iterator[IO]:
    """A temporary file beside ``path``, renamed onto it when the block ends without an
    error: until then, and when anything fails, an existing ``path`` stays as it was.

    Args:
        path: the file to write.
        mode: "w" or "wb".
        fsync: flush to the disk before the rename (off for caches).

    Raises:
        OSError: the directory or the file cannot be written (the temporary file is removed).
    """
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".%s.tmp-" % os.path.basename(path))
    try:
        with os.fdopen(fd, mode) as f:
            yield f
            f.flush()
            if fsync:
                os.fsync(f.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
