"""Logs read and prepared before, answered again from the cache folder.

:func:`~energy_planner.measurements.load_logs` of CSV/Parquet files and
:func:`~energy_planner.calibration.prepare_logs` (data checks, the repair guard, cleaning,
windows, whole runs) keep what they computed in the project's cache folder
(:func:`~energy_planner.io.atomic.cache_root`, folder ``logs``): the next command on the
same folder (``fit``, then ``figures``, ``diagnose``, ``discover``) reads the result back
instead of reading and checking the files again.

What makes an entry the same (its key, a SHA-256 of all of it):

* ``load_logs``: each file's path as given and resolved, its size, modification and
  change times, inode and device; the load options; ``prepare_logs``: the samples'
  content (columns, types, index and every value: pandas' per-row hashes) and every
  argument;
* the environment variables ``ENERGY_PLANNER_*``; the Python, numpy, pandas, pyarrow and
  scipy versions; the source of every module of the package; and the values, as the
  process holds them, of the module-level names of the modules that compute the result
  (a constant or a function replaced at run time is another entry).

Kept only: results computed without a warning (a read or a preparation that warned, or
raised, is done afresh every time, so the same warnings and errors are seen every time),
``load_logs`` of tables only (no ROS bag), none of them changed while read nor written
less than ``logs.SETTLED_S`` (0.2 s) before the read ended (a rewrite within the same
tick of the file system's clock could leave the same size and times), ``prepare_logs``
without a ``terrain`` and with the default or formula ``guard_terms``, entries of at most
:data:`MAX_ENTRY_BYTES`.
The :data:`KEEP` most recently used entries stay, :data:`MAX_BYTES` in all. An entry is
a pickle (the user's own cache folder, as the generated kernels beside it) followed by
its BLAKE2b digest: a truncated or altered entry is ignored (and replaced by the next
write). Written atomically (:func:`~energy_planner.io.atomic.atomic_path`); a cache
folder that cannot be written or read costs nothing but the cache.
``ENERGY_PLANNER_LOG_CACHE=0`` switches it off.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import os
import pickle
import sys
import types
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

__all__ = [
    "ENV_SWITCH",
    "KEEP",
    "MAX_BYTES",
    "MAX_ENTRY_BYTES",
    "digest",
    "enabled",
    "folder",
    "keep",
    "read",
    "warnings_shown",
]

#: Entries kept in the cache folder (the most recently used).
KEEP = 16
#: Bytes kept in the cache folder in all (the most recently used entries first).
MAX_BYTES = 1 << 30
#: Largest entry written, bytes.
MAX_ENTRY_BYTES = 256 << 20
#: ``ENERGY_PLANNER_LOG_CACHE=0`` switches the cache off.
ENV_SWITCH = "ENERGY_PLANNER_LOG_CACHE"
#: First bytes of an entry (the format's version).
MAGIC = b"energy_planner-logs-1\n"
_DIGEST = 32
#: Bytes hashed at a time when an entry is read.
_CHUNK = 1 << 20


def enabled() -> bool:
    """False when ``ENERGY_PLANNER_LOG_CACHE=0``."""
    return os.environ.get(ENV_SWITCH, "1").strip() != "0"


def folder() -> Path:
    """The folder of the entries (``logs`` in :func:`~energy_planner.io.atomic.cache_root`)."""
    from energy_planner.io.atomic import cache_root

    return cache_root() / "logs"


@functools.lru_cache(maxsize=1)
def _code_stamp() -> str:
    """The package's source and the versions of what computes the results."""
    from importlib import metadata

    h = hashlib.sha256(sys.version.encode())
    for dist in ("numpy", "pandas", "pyarrow", "scipy"):
        mod = sys.modules.get(dist)  # imported already: its version without a metadata scan
        try:
            version = getattr(mod, "__version__", None) or metadata.version(dist)
        except metadata.PackageNotFoundError:
            version = "none"
        h.update(f"\n{dist}={version}".encode())
    root = Path(__file__).resolve().parent.parent
    for f in sorted(root.rglob("*.py")):
        with contextlib.suppress(OSError):
            h.update(f"\n{f.relative_to(root)}\n".encode())
            h.update(f.read_bytes())
    return h.hexdigest()


def _value_stamp(v: Any, depth: int = 0) -> str | None:
    """A module-level value as text (None: not part of the key)."""
    if isinstance(v, types.ModuleType):
        return None
    if v is None or isinstance(v, bool | int | float | complex | str | bytes):
        return repr(v)
    qual = getattr(v, "__qualname__", None)
    if callable(v) and qual is not None:
        return f"{getattr(v, '__module__', '?')}.{qual}"
    if depth < 3 and isinstance(v, tuple | list | frozenset | set):
        items = [_value_stamp(x, depth + 1) for x in v]
        text = [str(x) for x in items]
        if isinstance(v, frozenset | set):
            text.sort()
        return f"{type(v).__name__}({', '.join(text)})"
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return repr(v)
    return None


def _module_stamp(modules: Iterable[str]) -> str:
    """The module-level names of ``modules`` as the process holds them now.

    Constants (numbers, text, tuples and sets of them, frozen settings) and the functions
    and classes each name holds (by module and qualified name): a test or a user that
    replaces one at run time gets its own entries. Mutable state (dicts, caches) is not
    a setting and is left out.
    """
    import importlib

    parts = []
    for name in sorted(modules):
        try:
            mod = sys.modules.get(name) or importlib.import_module(name)
        except ImportError:  # the computation cannot import it either: it raises there
            parts.append(f"{name}: not importable")
            continue
        for k, v in sorted(vars(mod).items()):
            if k.startswith("__"):
                continue
            try:
                text = _value_stamp(v)
            except Exception:  # noqa: BLE001 - an object that answers nothing: its type
                text = type(v).__qualname__
            if text is not None:
                parts.append(f"{name}.{k}={text}")
    return "\n".join(parts)


def _env_stamp() -> str:
    return "\n".join(
        sorted(f"{k}={v}" for k, v in os.environ.items() if k.startswith("ENERGY_PLANNER_"))
    )


def digest(kind: str, parts: Iterable[str], modules: Iterable[str]) -> str:
    """The key of an entry of ``kind`` from what it depends on (``parts``, ``modules``)."""
    h = hashlib.sha256(f"{kind}\n{_code_stamp()}\n{_env_stamp()}\n".encode())
    h.update(_module_stamp(modules).encode())
    for p in parts:
        h.update(b"\n")
        h.update(p.encode("utf-8", "surrogateescape"))
    return h.hexdigest()[:40]


def _entry(kind: str, key: str) -> Path:
    return folder() / f"{kind}_{key}.pkl"


def read(kind: str, key: str | None) -> Any:
    """The object kept as entry ``key`` of ``kind``; None when missing or unreadable.

    The entry's digest is checked by chunks and the object is unpickled from the file:
    no copy of the entry's bytes is held beside the object it becomes.
    """
    if key is None or not enabled():
        return None
    n = len(MAGIC)
    try:
        path = _entry(kind, key)
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size - n - _DIGEST
            if size < 0 or f.read(n) != MAGIC:
                return None
            h = hashlib.blake2b(digest_size=_DIGEST)
            left = size
            while left > 0:
                chunk = f.read(min(left, _CHUNK))
                if not chunk:
                    return None
                h.update(chunk)
                left -= len(chunk)
            if h.digest() != f.read(_DIGEST):
                return None
            f.seek(n)
            try:
                obj = pickle.load(f)
            except Exception:  # noqa: BLE001 - an entry of another build: computed afresh
                return None
    except (OSError, RuntimeError, KeyError):  # no entry, no home folder
        return None
    with contextlib.suppress(OSError):
        os.utime(path)  # recently used: kept by the pruning
    return obj


class _TooBig(Exception):
    """An entry past :data:`MAX_ENTRY_BYTES`: not kept."""


class _Sink:
    """A file that hashes what is written to it and refuses more than ``limit`` bytes."""

    def __init__(self, f: Any, limit: int) -> None:
        self.f, self.limit, self.n = f, limit, 0
        self.h = hashlib.blake2b(digest_size=_DIGEST)

    def write(self, b: Any) -> int:
        m = memoryview(b)
        self.n += m.nbytes
        if self.n > self.limit:
            raise _TooBig
        self.h.update(m)
        return self.f.write(m)


def keep(kind: str, key: str | None, obj: Any) -> bool:
    """Write ``obj`` as entry ``key`` of ``kind`` (an optimisation: never raises).

    Returns whether an entry was written.
    """
    if key is None or not enabled():
        return False
    from energy_planner.io.atomic import atomic_path

    try:
        path = _entry(kind, key)
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            f.write(MAGIC)
            sink = _Sink(f, MAX_ENTRY_BYTES)
            # streamed: the pickle's bytes are never all in memory beside the object
            pickle.dump(obj, sink, protocol=5)
            f.write(sink.h.digest())
        _prune(path.parent)
    except _TooBig:
        return False
    except (OSError, RuntimeError, KeyError):  # OutputError is an OSError
        return False
    except Exception:  # noqa: BLE001 - an object that cannot be pickled is not kept
        return False
    return True


def _prune(where: Path, keep: int = KEEP, max_bytes: int = MAX_BYTES) -> None:
    """Delete the entries of ``where`` beyond the ``keep`` most recently used, or ``max_bytes``."""
    entries = []
    for f in where.glob("*.pkl"):
        with contextlib.suppress(OSError):
            st = f.stat()
            entries.append((st.st_mtime_ns, st.st_size, f))
    entries.sort(key=lambda e: e[0], reverse=True)
    total = 0
    for i, (_, size, f) in enumerate(entries):
        total += size
        if i >= keep or total > max_bytes:
            with contextlib.suppress(OSError):
                f.unlink()


@contextlib.contextmanager
def warnings_shown() -> Iterator[list[warnings.WarningMessage]]:
    """Record the warnings of the block, then show them as they would have been shown.

    The filters apply as always (an ignored warning is not shown, an ``error`` one
    raises); the list tells the caller whether the block warned (a result that warned
    is not kept).
    """
    caught: list[warnings.WarningMessage] = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            yield caught
    finally:  # shown as they would have been (the filters applied already), raised or not
        for w in caught:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno, w.file, w.line)
