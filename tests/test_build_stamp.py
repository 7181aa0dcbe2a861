"""The compiled core's source fingerprint (poseonly/_build.py, CMakeLists.txt): a checkout whose
src/core changed since its build refuses to import with the way out, instead of failing later with
argument errors far from the cause."""

from __future__ import annotations

import importlib.util
import shutil
import sys
from pathlib import Path

import pytest

from poseonly import _build, _core


def test_the_build_fingerprint_is_the_checkouts():
    """CMake's digest of src/core (compiled in) equals the one Python computes from the same files."""
    core = _build.checkout_core_dir()
    if core is None:
        pytest.skip("an installed package: no sources beside it")
    assert len(_core.SOURCE_HASH) == 64
    assert _build.source_hash(core) == _core.SOURCE_HASH


def test_a_stale_core_is_refused_with_the_way_out(monkeypatch):
    if _build.checkout_core_dir() is None:
        pytest.skip("an installed package: no sources beside it")
    monkeypatch.delenv(_build.ALLOW_STALE_ENV, raising=False)
    with pytest.raises(_build.StaleCoreError, match=r"rebuild it with `pip install -e \.`.*POSEONLY_ALLOW_STALE_CORE=1"):
        _build.check_core_build("0" * 64)
    assert issubclass(_build.StaleCoreError, ImportError)
    monkeypatch.setenv(_build.ALLOW_STALE_ENV, "1")
    with pytest.warns(RuntimeWarning, match="importing anyway"):
        _build.check_core_build("0" * 64)
    _build.check_core_build(_core.SOURCE_HASH)  # the current build: nothing


def test_the_digest_follows_every_source_and_only_them(tmp_path):
    """A changed byte in any .h / .cpp changes the digest; other files do not; the order is by name."""
    core = tmp_path / "src" / "core"
    core.mkdir(parents=True)
    (core / "b.cpp").write_bytes(b"int b;\n")
    (core / "a.h").write_bytes(b"int a;\n")
    h0 = _build.source_hash(core)
    (core / "notes.txt").write_text("not a source")
    assert _build.source_hash(core) == h0
    (core / "a.h").write_bytes(b"int a; \n")
    assert _build.source_hash(core) != h0


def test_an_installed_copy_is_not_checked(tmp_path):
    """_build.py without a checkout around it (a wheel in site-packages) finds no sources."""
    pkg = tmp_path / "lib" / "site-packages" / "poseonly"
    pkg.mkdir(parents=True)
    shutil.copy(Path(_build.__file__), pkg / "_build.py")
    (tmp_path / "lib" / "site-packages" / "core").mkdir()  # an unrelated package named core
    spec = importlib.util.spec_from_file_location("poseonly_build_copy", pkg / "_build.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules["poseonly_build_copy"] = mod
    try:
        spec.loader.exec_module(mod)
        assert mod.checkout_core_dir() is None
        mod.check_core_build("0" * 64)  # nothing to compare with: no error
    finally:
        del sys.modules["poseonly_build_copy"]
