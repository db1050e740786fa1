"""Atomic file output: a temporary file beside the destination, renamed when complete.

Every file the project writes goes through :func:`atomic_path` (directly or through
:func:`write_text`, :func:`write_bytes`, :func:`write_json` and the GeoTIFF/GeoJSON
writers). The destination therefore holds either the previous file or the complete new
one, never a partial one:

* on success the temporary file is renamed over the destination (:func:`os.replace`,
  atomic on POSIX and Windows within one file system);
* on an exception, or a SIGTERM (turned into ``SystemExit(143)`` while the file is being
  written, in the main thread), the temporary file is removed and the destination is
  left as it was.

The temporary file keeps the destination's suffix (``.map.tif`` -> ``.map.<random>.tmp.tif``)
so that writers that choose a format from the name (rasterio, matplotlib) still do.

Examples
--------
>>> import tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> _ = write_text(d / "a.txt", "first")
>>> try:
...     with atomic_path(d / "a.txt") as tmp:
...         _ = tmp.write_text("half")
...         raise RuntimeError("stopped")
... except RuntimeError:
...     pass
>>> (d / "a.txt").read_text(), sorted(p.name for p in d.iterdir())
('first', ['a.txt'])
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

__all__ = [
    "atomic_path",
    "content_id",
    "save_figure",
    "write_bytes",
    "write_json",
    "write_text",
]


class _Terminated(SystemExit):
    """SIGTERM received while an output was being written (exit status 143)."""


def _on_sigterm(signum: int, frame: Any) -> None:
    raise _Terminated(128 + signum)


@contextlib.contextmanager
def _sigterm_raises() -> Iterator[None]:
    """Turn SIGTERM into ``SystemExit(143)`` (main thread, default handler only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    try:
        previous = signal.getsignal(signal.SIGTERM)
    except (ValueError, AttributeError):  # pragma: no cover - no signals here
        yield
        return
    if previous not in (signal.SIG_DFL, None):
        yield  # someone else handles SIGTERM (or a nested atomic_path already does)
        return
    signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _read_umask() -> int:
    umask = os.umask(0)  # read once, at import (os.umask can only be read by setting it)
    os.umask(umask)
    return umask


_UMASK = _read_umask()


def _mode_for(dest: Path) -> int:
    """Permissions of the new file: the old file's, else 0o666 minus the umask."""
    try:
        return dest.stat().st_mode & 0o7777
    except OSError:
        return 0o666 & ~_UMASK


@contextlib.contextmanager
def atomic_path(dest: str | os.PathLike[str], *, create: bool = True) -> Iterator[Path]:
    """Yield a temporary path beside ``dest``; rename it to ``dest`` on success.

    Parameters
    ----------
    dest : str or path-like
        The file to (re)write. Its directory must exist.
    create : bool
        True: the temporary path is an empty file. False: it does not exist yet (for
        writers that refuse an existing path or make a directory, such as ROS bag
        writers); a directory is renamed to ``dest``, which must not exist then.

    Yields
    ------
    pathlib.Path
        An empty temporary file in the same directory, with the same suffix. Write it
        completely (close it) before the block ends.

    Raises
    ------
    OSError
        The directory does not exist or is not writable.

    Notes
    -----
    On an exception (including ``SystemExit(143)`` from SIGTERM and
    :class:`KeyboardInterrupt`) the temporary file is removed and the exception
    propagates; ``dest`` is untouched. A SIGKILL leaves ``dest`` untouched too, and a
    stray ``.<name>.<random>.tmp<suffix>`` file beside it.
    """
    dest = Path(dest)
    if not create:
        with _atomic_new(dest) as tmp:
            yield tmp
        return
    fd, name = tempfile.mkstemp(
        dir=dest.parent if str(dest.parent) else ".",
        prefix=f".{dest.stem}.",
        suffix=f".tmp{dest.suffix}",
    )
    os.close(fd)
    tmp = Path(name)
    done = False
    try:
        with _sigterm_raises():
            yield tmp
            os.chmod(tmp, _mode_for(dest))
            os.replace(tmp, dest)
            done = True
    finally:
        if not done:
            with contextlib.suppress(OSError):
                tmp.unlink()


@contextlib.contextmanager
def _atomic_new(dest: Path) -> Iterator[Path]:
    """:func:`atomic_path` with ``create=False``: a fresh name in a private temp folder."""
    import shutil

    parent = dest.parent if str(dest.parent) else Path(".")
    holder = Path(tempfile.mkdtemp(dir=parent, prefix=f".{dest.name}.", suffix=".tmp"))
    tmp = holder / dest.name
    try:
        with _sigterm_raises():
            yield tmp
            os.replace(tmp, dest)
    finally:
        shutil.rmtree(holder, ignore_errors=True)


def write_bytes(dest: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``dest`` atomically and return ``Path(dest)``."""
    with atomic_path(dest) as tmp:
        tmp.write_bytes(data)
    return Path(dest)


def write_text(dest: str | os.PathLike[str], text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``dest`` atomically and return ``Path(dest)``."""
    with atomic_path(dest) as tmp:
        tmp.write_text(text, encoding=encoding)
    return Path(dest)


def write_json(
    dest: str | os.PathLike[str], obj: Any, *, indent: int | None = 2, **dumps_kw: Any
) -> Path:
    r"""Write ``obj`` as JSON (UTF-8, a trailing newline) to ``dest`` atomically.

    The document is serialised before the file is touched, so an object that cannot be
    serialised raises ``TypeError``/``ValueError`` and leaves ``dest`` as it was.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = write_json(pathlib.Path(tempfile.mkdtemp()) / "m.json", {"a": 1})
    >>> p.read_text()
    '{\n  "a": 1\n}\n'
    """
    text = json.dumps(obj, indent=indent, **dumps_kw) + "\n"
    return write_text(dest, text)


def save_figure(fig: Any, dest: str | os.PathLike[str], **savefig_kw: Any) -> Path:
    """``fig.savefig`` to ``dest`` atomically (the format from ``dest``'s suffix).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    dest : str or path-like
    **savefig_kw
        Passed to ``savefig`` (``dpi``, ``bbox_inches``, ...).

    Returns
    -------
    pathlib.Path
    """
    with atomic_path(dest) as tmp:
        fig.savefig(tmp, **savefig_kw)
    return Path(dest)


def content_id(obj: Any) -> str:
    """A short, stable id of a JSON document's content: ``"sha256:"`` + 16 hex digits.

    The same document (keys in any order) gives the same id, so a result can name the
    model it used (``plan --json``'s ``model.id``) and a reader can check it against a
    model file (``EnergyModel.load(p).to_dict()``).

    Examples
    --------
    >>> content_id({"b": 1, "a": [1.5]}) == content_id({"a": [1.5], "b": 1})
    True
    >>> content_id({"a": 1})
    'sha256:015abd7f5cc57a2d'
    """
    import hashlib

    text = json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return "sha256:" + hashlib.sha256(text.encode()).hexdigest()[:16]
