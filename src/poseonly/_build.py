"""Is the compiled core (``poseonly._core``) built from the sources next to it?

An editable install (``pip install -e .``) imports ``src/poseonly`` from the checkout and the core from
its last build: after a pull or an edit of ``src/core`` without a rebuild the two disagree, and calls
fail with argument errors far from the cause (a helper's benchmark). The build compiles in a
fingerprint of ``src/core`` (``_core.SOURCE_HASH``, CMakeLists.txt); in a checkout the package compares
it with the sources' at import. An installed wheel has no sources beside it and is not checked.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

# POSEONLY_ALLOW_STALE_CORE=1: warn instead of refusing (a C++ developer importing mid-edit)
ALLOW_STALE_ENV = "POSEONLY_ALLOW_STALE_CORE"


class StaleCoreError(ImportError):
    """The compiled core was built from other sources than the checkout's ``src/core`` holds."""


def checkout_core_dir() -> Path | None:
    """``src/core`` of the checkout this package is imported from, or None (an installed package)."""
    root = Path(__file__).resolve().parents[2]
    core = root / "src" / "core"
    cmake = root / "CMakeLists.txt"
    if not (core.is_dir() and (core / "bindings.cpp").is_file() and cmake.is_file()):
        return None
    try:
        return core if "poseonly_core" in cmake.read_text(encoding="utf-8", errors="replace") else None
    except OSError:
        return None


def source_hash(core: Path) -> str:
    """SHA-256 over ``"name:sha256-of-file\\n"`` of every ``*.h`` and ``*.cpp`` in ``core``, in name
    order: the digest CMakeLists.txt compiles in."""
    files = sorted((p for p in core.iterdir() if p.suffix in (".h", ".cpp") and p.is_file()), key=lambda p: p.name.encode())
    lines = "".join(f"{p.name}:{hashlib.sha256(p.read_bytes()).hexdigest()}\n" for p in files)
    return hashlib.sha256(lines.encode()).hexdigest()


def check_core_build(built: str) -> None:
    """Raise :class:`StaleCoreError` (a warning with ``POSEONLY_ALLOW_STALE_CORE=1``) where this is a
    checkout whose ``src/core`` differs from the sources the core ``built`` its fingerprint from."""
    core = checkout_core_dir()
    if core is None or not built:
        return
    if source_hash(core) == built:
        return
    msg = f"poseonly's compiled core was built from other sources than {core} holds now (edited or pulled since the last build): rebuild it with `pip install -e .` in the checkout"
    if os.environ.get(ALLOW_STALE_ENV) == "1":
        import warnings

        warnings.warn(msg + f" ({ALLOW_STALE_ENV}=1: importing anyway)", RuntimeWarning, stacklevel=3)
        return
    raise StaleCoreError(msg + f"; {ALLOW_STALE_ENV}=1 imports it anyway")


if __package__ == "poseonly":  # imported as the package's first module (not a copy in a test)
    from . import _core

    check_core_build(getattr(_core, "SOURCE_HASH", "?"))
