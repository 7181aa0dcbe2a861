"""Pair lists: one pair of image names a line (COLMAP's match-list format, hloc's pair files), ``#``
comments and blank lines skipped. One parser for ``poseonly colmap verify --pairs`` and ``poseonly sfm
--pairs``."""

from __future__ import annotations

from collections.abc import Container, Iterable

from ..geometry import InputError

__all__ = ["parse_pair_names"]


def parse_pair_names(lines: Iterable[str], source: str = "pairs file", known: Container[str] | None = None, known_as: str = "a known image") -> list[tuple[str, str]]:
    """``(name1, name2)`` of every line, in order (duplicates kept); a line with other than two names,
    an image paired with itself, or (with ``known``) a name not in ``known`` ("... is not ``known_as``")
    is an :class:`InputError` naming ``source`` and the line. A byte-order mark at the start of the
    first line is ignored."""
    out: list[tuple[str, str]] = []
    for k, line in enumerate(lines, 1):
        text = line.lstrip("\ufeff") if k == 1 else line
        parts = text.split("#", 1)[0].split()
        if not parts:
            continue
        if len(parts) != 2:
            raise InputError(f"{source} line {k}: expected 'IMAGE_NAME1 IMAGE_NAME2', got {line.strip()!r}")
        if parts[0] == parts[1]:
            raise InputError(f"{source} line {k}: an image paired with itself ({parts[0]!r})")
        if known is not None:
            for nm in parts:
                if nm not in known:
                    raise InputError(f"{source} line {k}: {nm!r} is not {known_as}")
        out.append((parts[0], parts[1]))
    return out
