"""Small helpers for atomic writers."""

from __future__ import annotations

import os


def publish(tmp: str | os.PathLike, path: str | os.PathLike) -> None:
    """Give ``tmp`` (made by ``tempfile.mkstemp``, mode 0600) the mode a plain ``open`` would have
    created (``0666`` minus the umask), then move it onto ``path`` atomically."""
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(tmp, 0o666 & ~mask)
    os.replace(tmp, path)
