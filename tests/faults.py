"""Test helpers that make a folder read-only or small (a full disk), for the fault tests.

A non-root user gets a read-only folder from its permissions; root ignores permissions,
so for root the folder is a small tmpfs remounted read-only. A full disk is a tmpfs of a
given size (``mount -t tmpfs -o size=1m tmpfs DIR``): root only; the test is skipped
with the reason when mounting is not permitted (a container without CAP_SYS_ADMIN).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest


def _mount(*args: str) -> str | None:
    """Run ``mount`` with ``args``; the error text, or None on success."""
    if shutil.which("mount") is None:
        return "no mount command"
    r = subprocess.run(["mount", *args], capture_output=True, text=True)
    return None if r.returncode == 0 else (r.stderr.strip() or f"mount exit {r.returncode}")


def _umount(path: Path) -> None:
    subprocess.run(["umount", "-l", str(path)], capture_output=True)


@contextlib.contextmanager
def small_disk(path: Path, size: str = "1m") -> Iterator[Path]:
    """``path`` as a tmpfs of ``size``: writes beyond it fail with ENOSPC."""
    path.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0:
        pytest.skip("a small tmpfs needs root (mount -t tmpfs): not permitted here")
    err = _mount("-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path))
    if err:
        pytest.skip(f"cannot mount a small tmpfs for a full disk: {err}")
    try:
        yield path
    finally:
        _umount(path)


@contextlib.contextmanager
def read_only_dir(path: Path, files: dict[str, bytes] | None = None) -> Iterator[Path]:
    """``path`` holding ``files``, then read-only (permissions, or a read-only mount for root)."""
    path.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0:
        for name, data in (files or {}).items():
            (path / name).write_bytes(data)
        path.chmod(0o555)
        try:
            yield path
        finally:
            path.chmod(0o755)
        return
    err = _mount("-t", "tmpfs", "-o", "size=4m", "tmpfs", str(path))
    if err:
        pytest.skip(f"root ignores permissions and a read-only tmpfs cannot be mounted: {err}")
    try:
        for name, data in (files or {}).items():
            (path / name).write_bytes(data)
        err = _mount("-o", "remount,ro", str(path))
        if err:
            pytest.skip(f"cannot remount the tmpfs read-only: {err}")
        yield path
    finally:
        _umount(path)


def named_files(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make ``energy_planner.io`` write as where files cannot be unnamed (no ``O_TMPFILE``).

    ``os.open`` with ``O_TMPFILE`` fails with ``EOPNOTSUPP``, as on a file system without
    it: the writers fall back to a hidden temporary name beside the destination.
    """
    import errno

    from energy_planner.io import atomic

    real_open = os.open
    flag = getattr(os, "O_TMPFILE", 0)

    def refusing(path, flags, *args, **kwargs):
        if flag and flags & flag == flag:
            raise OSError(errno.EOPNOTSUPP, "Operation not supported", str(path))
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(atomic.os, "open", refusing)
