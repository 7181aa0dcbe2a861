"""pycolmap, imported with Python's SIGTERM handling kept.

pycolmap's module initialisation installs glog's failure signal handler, which replaces the process's
SIGTERM action: a terminated run then prints a native stack dump instead of ending as the caller
(Python's default, or the CLI's clean exit 143) asked. The first import here re-installs whatever
SIGTERM handler Python had registered.
"""

from __future__ import annotations

import signal
import sys
import threading
from types import ModuleType

__all__ = ["import_pycolmap"]


def import_pycolmap() -> ModuleType:
    """``pycolmap`` (``ImportError`` where it is not installed). On its first import in the main
    thread, the SIGTERM handler Python had registered (``signal.SIG_DFL`` unless the program set one)
    is put back in place of glog's."""
    first = "pycolmap" not in sys.modules
    try:
        import pycolmap
    except ImportError as exc:  # name the extra (a packaging trial: a bare "No module named 'pycolmap'")
        raise ImportError(f"pycolmap is required for this (COLMAP databases, models, two-view geometries); install it with pip install poseonly[colmap] ({exc})") from exc

    if first and threading.current_thread() is threading.main_thread():
        handler = signal.getsignal(signal.SIGTERM)
        signal.signal(signal.SIGTERM, signal.SIG_DFL if handler is None else handler)
    return pycolmap
