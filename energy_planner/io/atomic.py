"""Atomic file output: the destination holds the previous file or the complete new one.

Every file the project writes goes through :func:`atomic_path` (directly or through
:func:`write_text`, :func:`write_bytes`, :func:`write_json` and the GeoTIFF/GeoJSON
writers). The destination therefore holds either the previous file or the complete new
one, never a partial one, and a killed write leaves nothing beside it:

* the destination's folder is created if missing (one rule for every output of every
  command); a folder that cannot be written, a full disk or a destination that is a
  folder raise :class:`~energy_planner.errors.OutputError` naming the path;
* on Linux the new file is an *unnamed* file on the destination's file system
  (``O_TMPFILE``): it has no name until it is complete, so a SIGKILL (or a power cut)
  while it is written leaves nothing beside the destination. Writers that need a path
  whose suffix chooses the format (rasterio/GDAL, matplotlib, pyarrow) are given a
  symbolic link with the destination's name that reaches the file
  (``/proc/<pid>/fd/<fd>``), in the process's private folder
  ``energy_planner.<pid>.<random>`` of the temporary folder (removed at exit; after a
  kill, by the next process that writes). When the block ends
  the file gets a hidden name beside the destination (``linkat``) that is at once
  renamed over it (:func:`os.replace`, atomic on POSIX within one file system);
* elsewhere (another system, a file system without ``O_TMPFILE``) the file is written
  under a hidden temporary name beside the destination,
  ``.<stem>.<pid>.<random>.tmp<suffix>``, renamed when complete;
* on an exception, or a SIGTERM (turned into ``SystemExit(143)`` while the file is being
  written, in the main thread), the temporary file is removed and the destination is
  left as it was.

What a SIGKILL can leave beside the destination is therefore a hidden
``.<stem>.<pid>.<random>.tmp<suffix>`` file: during the whole write where files cannot
be unnamed, and on Linux only between the two system calls that name and rename a
complete file. The next write to the same destination removes it (:func:`remove_stale`;
the writer's process id is in the name and a live writer holds a lock on it, so
concurrent writers never remove each other's files). A whole folder (a simulated
campaign, a ROS bag) is written with :func:`atomic_dir` (or ``atomic_path(...,
create=False)``): built in a private folder on the same file system when there is one
(the temporary folder, or the project's cache folder :func:`cache_root`), and moved in
at once, so a kill leaves nothing beside it either; where there is none, built in a
hidden folder ``.<name>.<pid>.<random>.tmp`` beside it that the next write removes. The
files of such a folder may be written straight into it (no reader sees it before it is
moved in): the simulator writes a campaign's run logs so.

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
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any, NoReturn

__all__ = [
    "atomic_dir",
    "atomic_path",
    "cache_root",
    "check_folder_output",
    "content_id",
    "output_error",
    "remove_stale",
    "save_figure",
    "scratch_path",
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


#: The temporary name of a file being written: ``.<stem>.<pid>.<random>.tmp<suffix>``
#: (the writer's process id, so that a later write can tell a dead writer's leftover),
#: and of the GDAL sidecars written beside it.
_TMP_FILE = r"\.+{stem}\.(\d+)\.[A-Za-z0-9_]+\.tmp(?:\..*)?{suffix}(?:\.ovr|\.msk)?(?:\.aux\.xml)?"
#: The temporary folder of a folder (or a file written by name) being made:
#: ``.<name>.<pid>.<random>.tmp``.
_TMP_DIR = r"\.{name}\.(\d+)\.[A-Za-z0-9_]+\.tmp"


def _alive(pid: int) -> bool:
    """True if a process ``pid`` exists (or may: not ours to signal)."""
    if pid == os.getpid() or os.name == "nt":  # Windows: os.kill would end the process
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True
    return True


def _lock(fd: int) -> bool:
    """Take an exclusive lock on ``fd`` without waiting; False if someone holds it."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: the process id alone decides
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    except OSError:  # pragma: no cover - a file system without locks: the pid decides
        return True
    return True


def _held(path: Path) -> bool:
    """True if a live writer holds ``path`` (its lock; a file or a folder)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return True  # gone already, or not ours to read: leave it
    try:
        return not _lock(fd)
    finally:
        os.close(fd)


def remove_stale(dest: str | os.PathLike[str]) -> list[Path]:
    """Remove what killed writers of ``dest`` left beside it; return the removed paths.

    A write that gets SIGKILL (or loses power) cannot clean up: its temporary file
    ``.<stem>.<pid>.<random>.tmp<suffix>`` (or folder ``.<name>.<pid>.<random>.tmp``)
    stays beside the destination. Every write to ``dest`` calls this first: a leftover
    is removed when its writer's process is gone and no one holds its lock (a live
    writer holds an exclusive ``flock`` on it while it writes), so two processes writing
    the same output never remove each other's work.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / ".map.999999999.abc123.tmp.tif").write_bytes(b"half a map")
    >>> [p.name for p in remove_stale(d / "map.tif")], list(d.iterdir())
    (['.map.999999999.abc123.tmp.tif'], [])
    """
    import re
    import shutil

    dest = Path(dest)
    parent = dest.parent if str(dest.parent) else Path(".")
    head = f"{dest.stem}."
    removed: list[Path] = []
    try:  # a temporary name of a temporary file (a scratch file written atomically) too
        entries = [
            e
            for e in os.scandir(parent)
            if e.name[:1] == "." and e.name.lstrip(".").startswith(head)
        ]
    except OSError:
        return removed
    if not entries:  # the usual case: the patterns (one compile per name) are not needed
        return removed
    pats = (
        re.compile(_TMP_FILE.format(stem=re.escape(dest.stem), suffix=re.escape(dest.suffix))),
        re.compile(_TMP_DIR.format(name=re.escape(dest.name))),
    )
    for e in entries:
        m = next((m for m in (p.fullmatch(e.name) for p in pats) if m), None)
        if m is None or _alive(int(m.group(1))):
            continue
        path = Path(e.path)
        if _held(path):
            continue
        try:
            if e.is_dir(follow_symlinks=False):
                shutil.rmtree(path)
            else:
                path.unlink()
        except OSError:
            continue
        removed.append(path)
    return removed


def output_error(dest: str | os.PathLike[str], exc: OSError, doing: str = "write") -> Exception:
    """An :class:`~energy_planner.errors.OutputError` for ``exc`` met writing ``dest``.

    The message names ``dest``, the cause in words (a full disk, permission denied, ...)
    and that ``dest`` keeps its previous content. Library errors other than an
    ``OutputError`` come back as they are; an ``OutputError`` about a file inside
    ``dest`` (a folder being written whole) is told again about ``dest``.

    Examples
    --------
    >>> import errno
    >>> str(output_error("/no/such/map.tif", OSError(errno.ENOSPC, "No space left")))[:73]
    "cannot write '/no/such/map.tif': no space left on the device; nothing was"
    """
    import errno

    from energy_planner.errors import EnergyPlannerError, OutputError

    dest = Path(dest)
    if isinstance(exc, OutputError) and isinstance(exc.__cause__, OSError):
        exc = exc.__cause__
    if isinstance(exc, EnergyPlannerError):
        return exc
    why = (
        {
            errno.ENOSPC: "no space left on the device",
            errno.EDQUOT: "disk quota exceeded",
            errno.EACCES: "permission denied",
            errno.EPERM: "permission denied",
            errno.EROFS: "the file system is read-only",
            errno.EISDIR: "it is a folder",
        }.get(exc.errno or -1)
        or _full_disk(dest)
        or exc.strerror
        or str(exc)
    )
    if not dest.exists():
        kept = "nothing was written"
    else:
        kept = f"the previous {'folder' if dest.is_dir() else 'file'} is kept"
    return OutputError(
        f"cannot {doing} {str(dest)!r}: {why}; {kept}. Expected a writable folder with "
        "free space (choose another path or free some space)",
        path=str(dest),
        value=exc.strerror or str(exc),
        expected="a writable folder with free space",
    )


def _full_disk(dest: Path) -> str | None:
    """The words for a full disk when ``dest``'s file system is (nearly) full, else None.

    Writers such as GDAL report a full disk without its errno ("Write failed"). The file
    system is the one of ``dest`` itself when it exists (a link to an unnamed file is
    followed to the file's), else of its nearest existing folder.
    """
    for d in (dest, dest.parent, *dest.parent.parents):
        if d.exists():
            try:
                st = os.statvfs(d)
            except (OSError, AttributeError):
                return None
            if st.f_bavail * st.f_frsize < 64 * 1024:
                where = d if d.is_dir() else Path(os.path.realpath(d)).parent  # a link's file
                return f"no space left on the device ({where})"
            return None
    return None


def _reraise(dest: Path, exc: OSError, doing: str = "write") -> NoReturn:
    """Raise ``exc`` as an :class:`~energy_planner.errors.OutputError` (library errors as is)."""
    err = output_error(dest, exc, doing)
    if err is exc:
        raise exc
    raise err from exc


def _make_parent(dest: Path) -> Path:
    """Create ``dest``'s folder (and its parents) if missing; the one rule of outputs."""
    parent = dest.parent if str(dest.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        import errno

        blocker = next((p for p in (parent, *parent.parents) if p.is_file()), None)
        if blocker is not None or exc.errno == errno.EEXIST:
            exc = NotADirectoryError(
                errno.ENOTDIR, f"{str(blocker or parent)!r} is a file, not a folder"
            )
        _reraise(dest, exc, "create the folder of")
    return parent


#: The private folders of writes (links to unnamed files, folders being built):
#: ``energy_planner.<pid>.<random>``, in the temporary folder (or the cache folder).
_PRIVATE = "energy_planner"
_SWEPT: set[tuple[int, str]] = set()


def _sweep(base: Path, again: bool = False) -> None:
    """Remove the private folders in ``base`` that killed writers left (once a process).

    A folder is removed when its writer's process is gone and no one holds its lock.
    """
    import re
    import shutil

    key = (os.getpid(), str(base))
    if key in _SWEPT and not again:
        return
    _SWEPT.add(key)
    pat = re.compile(rf"{_PRIVATE}\.(\d+)\.[A-Za-z0-9_]+")
    try:
        entries = [e for e in os.scandir(base) if e.name.startswith(f"{_PRIVATE}.")]
    except OSError:
        return
    for e in entries:
        m = pat.fullmatch(e.name)
        if m is None or _alive(int(m.group(1))) or _held(Path(e.path)):
            continue
        with contextlib.suppress(OSError):
            if e.is_dir(follow_symlinks=False):
                shutil.rmtree(e.path)


@contextlib.contextmanager
def _private_dir(base: Path | None = None, *, sweep: bool = False) -> Iterator[Path]:
    """A new locked folder ``energy_planner.<pid>.<random>`` in ``base``, removed at the end.

    ``base`` defaults to the temporary folder (:func:`tempfile.gettempdir`). What killed
    processes left there is removed first (:func:`_sweep`: by each process once, or
    every time with ``sweep``).
    """
    base = Path(base or tempfile.gettempdir())
    _sweep(base, again=sweep)
    with _locked_folder(base, f"{_PRIVATE}.{os.getpid()}.") as d:
        yield d


@contextlib.contextmanager
def _locked_folder(base: Path, prefix: str, suffix: str = "") -> Iterator[Path]:
    """A new folder ``<prefix><random><suffix>`` in ``base``, locked while in use, then removed.

    The lock (``flock``) tells :func:`remove_stale` and :func:`_sweep` that its writer
    lives, whatever its process id says (another pid namespace).
    """
    import shutil

    d = Path(tempfile.mkdtemp(dir=base, prefix=prefix, suffix=suffix))
    try:
        fd: int | None = os.open(d, os.O_RDONLY)
    except OSError:  # pragma: no cover - a folder cannot be opened here (Windows)
        fd = None
    if fd is not None:
        _lock(fd)
    try:
        yield d
    finally:
        shutil.rmtree(d, ignore_errors=True)
        if fd is not None:
            os.close(fd)


def _open_unnamed(parent: Path, mode: int) -> int | None:
    """An unnamed file (``O_TMPFILE``) on ``parent``'s file system; None where unsupported.

    Unsupported: not Linux, no ``/proc`` to reach it by a path, or a file system (or
    kernel) without ``O_TMPFILE`` (``EOPNOTSUPP``, ``EISDIR``, ``EINVAL``). Other errors
    (permission denied, a full disk, a read-only file system) are raised.
    """
    import errno

    flag = getattr(os, "O_TMPFILE", None)
    if flag is None or not os.path.isdir("/proc/self/fd"):
        return None
    try:
        return os.open(parent, flag | os.O_RDWR, mode)
    except OSError as exc:
        if exc.errno in (errno.EOPNOTSUPP, errno.EISDIR, errno.EINVAL, errno.ENOSYS):
            return None
        raise


def _fd_path(fd: int) -> str:
    """The path that reaches open file ``fd`` of this process, from any process."""
    return f"/proc/{os.getpid()}/fd/{fd}"


#: This process's private folder of links: ``{pid: (folder, its locked fd)}``.
_LINKS: dict[int, tuple[Path, int | None]] = {}
_LINKS_LOCK = threading.Lock()


def _links_folder() -> Path:
    """The private folder of the process's links, in the temporary folder.

    Made once a process (a folder made and removed for each write costs a few ms on
    some disks), locked while the process lives, removed at its exit; what a killed
    process leaves is removed by the next one (:func:`_sweep`).
    """
    import atexit

    pid = os.getpid()
    with _LINKS_LOCK:
        got = _LINKS.get(pid)
        if got is not None and got[0].is_dir():
            return got[0]
        if got is not None and got[1] is not None:  # removed meanwhile (a /tmp cleaner)
            with contextlib.suppress(OSError):
                os.close(got[1])
        base = Path(tempfile.gettempdir())
        _sweep(base)
        folder = Path(tempfile.mkdtemp(dir=base, prefix=f"{_PRIVATE}.{pid}."))
        try:
            fd: int | None = os.open(folder, os.O_RDONLY)
        except OSError:  # pragma: no cover - a folder cannot be opened here (Windows)
            fd = None
        if fd is not None:
            _lock(fd)
        if not _LINKS:
            atexit.register(_remove_links_folder)
        _LINKS[pid] = (folder, fd)
        return folder


def _remove_links_folder() -> None:
    """Remove this process's private folder of links (at exit)."""
    import shutil

    got = _LINKS.pop(os.getpid(), None)
    if got is not None:
        shutil.rmtree(got[0], ignore_errors=True)
        if got[1] is not None:
            with contextlib.suppress(OSError):
                os.close(got[1])


#: The sidecar files GDAL may write beside a raster (``<name><suffix>``).
_SIDECARS = (".aux.xml", ".ovr", ".ovr.aux.xml", ".msk", ".msk.aux.xml")


@contextlib.contextmanager
def _reach(fd: int, name: str) -> Iterator[Path]:
    """A link named ``name`` to unnamed file ``fd`` in this process's private folder.

    When another thread writes a file of the same name at the same time, the link is in
    a folder of its own. The link (and any sidecar beside it) is removed at the end.
    """
    import shutil

    folder = _links_folder()
    own = None
    link = folder / name
    try:
        os.symlink(_fd_path(fd), link)
    except FileExistsError:
        own = Path(tempfile.mkdtemp(dir=folder))
        link = own / name
        os.symlink(_fd_path(fd), link)
    try:
        yield link
    finally:
        if own is not None:
            shutil.rmtree(own, ignore_errors=True)
        else:
            for p in (link, *(link.with_name(name + s) for s in _SIDECARS)):
                with contextlib.suppress(OSError):
                    p.unlink()


def _take_back(link: Path, fd: int) -> None:
    """Make ``fd`` hold what the writer left at ``link``.

    A writer that replaced the link by a file of its own (a rename over it) wrote there:
    that file is copied into ``fd``. A writer that removed it left nothing to rename:
    ``FileNotFoundError`` (as for a named temporary file removed).
    """
    import shutil

    if link.is_symlink() and os.readlink(link) == _fd_path(fd):
        return
    if not link.is_file() or link.is_symlink():
        raise FileNotFoundError(2, "the temporary file was removed by its writer", str(link))
    os.ftruncate(fd, 0)
    os.lseek(fd, 0, os.SEEK_SET)
    with open(link, "rb") as src, open(os.dup(fd), "wb") as out:
        shutil.copyfileobj(src, out, 1 << 20)


def _name(fd: int, dest: Path, parent: Path) -> Path:
    """Give unnamed file ``fd`` a hidden temporary name of ``dest`` in ``parent``."""
    import secrets

    proc = os.open("/proc/self/fd", os.O_RDONLY)
    try:
        while True:
            tmp = parent / f".{dest.stem}.{os.getpid()}.{secrets.token_hex(4)}.tmp{dest.suffix}"
            try:  # linkat(AT_SYMLINK_FOLLOW) through /proc: no privilege needed
                os.link(str(fd), tmp, src_dir_fd=proc, follow_symlinks=True)
            except FileExistsError:  # pragma: no cover - 32 random bits taken
                continue
            return tmp
    finally:
        os.close(proc)


def _carry_sidecars(written: Path, dest: Path, move: bool = False) -> None:
    """Put the sidecars a writer made beside file ``written`` beside ``dest``.

    GDAL may write ``<name>.aux.xml`` or ``<name>.ovr`` next to the file it writes (a
    dataset it cannot describe inside the file, external overviews): they become
    ``<dest>.aux.xml`` ..., after ``dest``: renamed (``move``, the same folder) or copied
    atomically (from the private folder).
    """
    import shutil

    for s in _SIDECARS:
        side = written.with_name(written.name + s)
        if not side.is_file():
            continue
        if move:
            os.replace(side, dest.with_name(dest.name + s))
            continue
        with atomic_path(dest.with_name(dest.name + s)) as tmp:
            shutil.copyfile(side, tmp)


@contextlib.contextmanager
def atomic_path(
    dest: str | os.PathLike[str], *, create: bool = True, shared: bool = False
) -> Iterator[Path]:
    """Yield a temporary path with ``dest``'s name; it becomes ``dest`` on success.

    Parameters
    ----------
    dest : str or path-like
        The file to (re)write. Its folder is created if missing (the one rule for every
        output of every command).
    create : bool
        True: the temporary path is an empty file. False: it does not exist yet (for
        writers that refuse an existing path or make a directory, such as ROS bag
        writers); a directory is moved to ``dest``, which must not exist then.
    shared : bool
        The path is opened by other machines too (the workers of a dask cluster): a
        hidden file beside ``dest``, as where files cannot be unnamed.

    Yields
    ------
    pathlib.Path
        ``create=True``: an empty temporary file with ``dest``'s suffix (on Linux a link,
        in a private temporary folder, to an unnamed file on ``dest``'s file system;
        elsewhere a hidden file beside ``dest``). Write it completely (close it) before
        the block ends; sidecar files written beside it (``<name>.aux.xml``) follow it.
        ``create=False``: a new name ``dest.name`` in a private folder on ``dest``'s
        file system (or in a hidden folder beside ``dest`` where there is none).

    Raises
    ------
    energy_planner.errors.OutputError
        The folder cannot be created or written, the disk is full, or ``dest`` is a
        folder (an ``OSError`` too). ``dest`` keeps its previous content.

    Notes
    -----
    On an exception (including ``SystemExit(143)`` from SIGTERM and
    :class:`KeyboardInterrupt`) the temporary file is removed and the exception
    propagates; ``dest`` is untouched. A SIGKILL leaves ``dest`` untouched too. On Linux
    it leaves nothing beside ``dest``, except when it falls between the two system calls
    that name the complete file (``linkat`` of ``/proc/self/fd/<fd>`` to a hidden
    ``.<stem>.<pid>.<random>.tmp<suffix>``) and rename it over ``dest``; where files
    cannot be unnamed that hidden file exists during the whole write. Either way the
    next write to ``dest`` removes it (:func:`remove_stale`: its writer is gone and
    holds no lock).
    """
    dest = Path(dest)
    parent = _make_parent(dest)
    remove_stale(dest)
    if not create:
        with _atomic_new(dest, parent) as tmp:
            yield tmp
        return
    if dest.is_dir():
        raise output_error(dest, IsADirectoryError(21, "Is a directory"))
    try:
        fd = None if shared else _open_unnamed(parent, 0o600)
    except OSError as exc:
        _reraise(dest, exc)
    with contextlib.ExitStack() as stack:
        if fd is not None:
            stack.callback(os.close, fd)
            try:
                link = stack.enter_context(_reach(fd, dest.name))
            except OSError:  # no private folder for the link (a full /tmp): a named file
                fd = None
        if fd is None:
            with _atomic_named(dest, parent) as tmp:
                yield tmp
            return
        _lock(fd)  # the name it gets at the end is held: remove_stale leaves it alone
        named: Path | None = None
        try:
            with _sigterm_raises():
                try:
                    yield link
                    _take_back(link, fd)
                    os.fchmod(fd, _mode_for(dest))
                    named = _name(fd, dest, parent)
                    os.replace(named, dest)  # a kill between the two leaves ``named``
                    named = None
                    _carry_sidecars(link, dest)
                except OSError as exc:
                    _reraise(dest, exc)
        finally:
            if named is not None:
                with contextlib.suppress(OSError):
                    named.unlink()


@contextlib.contextmanager
def _atomic_named(dest: Path, parent: Path) -> Iterator[Path]:
    """:func:`atomic_path` where files cannot be unnamed: a hidden file beside ``dest``."""
    try:
        fd, name = tempfile.mkstemp(
            dir=parent, prefix=f".{dest.stem}.{os.getpid()}.", suffix=f".tmp{dest.suffix}"
        )
    except OSError as exc:
        _reraise(dest, exc)
    _lock(fd)  # held until the file is renamed or removed: remove_stale leaves it alone
    tmp = Path(name)
    done = False
    try:
        with _sigterm_raises():
            try:
                yield tmp
                os.chmod(tmp, _mode_for(dest))
                os.replace(tmp, dest)
                done = True
                _carry_sidecars(tmp, dest, move=True)
            except OSError as exc:
                _reraise(dest, exc)
    finally:
        if not done:
            with contextlib.suppress(OSError):
                tmp.unlink()
            for s in _SIDECARS:
                with contextlib.suppress(OSError):
                    tmp.with_name(tmp.name + s).unlink()
        os.close(fd)


@contextlib.contextmanager
def scratch_path(dest: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a scratch file on ``dest``'s file system (its folder made), gone at the end.

    For work files an output needs on the same disk (an energy map computed on the
    working grid before it is resampled onto ``dest``'s). On Linux it is an unnamed file
    reached by a link in a private temporary folder, so a SIGKILL leaves nothing beside
    ``dest``; elsewhere it is a temporary name of ``dest``
    (``.<stem>.<pid>.<random>.tmp<suffix>``, locked while in use) that the next write to
    ``dest`` removes after a SIGKILL (:func:`remove_stale`).
    """
    dest = Path(dest)
    parent = _make_parent(dest)
    remove_stale(dest)
    name = ""
    try:
        fd = _open_unnamed(parent, 0o600)
        if fd is None:
            fd, name = tempfile.mkstemp(
                dir=parent, prefix=f".{dest.stem}.{os.getpid()}.", suffix=f".tmp{dest.suffix}"
            )
    except OSError as exc:
        _reraise(dest, exc)
    _lock(fd)
    try:
        if name:
            yield Path(name)
        else:
            with _reach(fd, dest.name) as link:
                yield link
    finally:
        if name:
            with contextlib.suppress(OSError):
                os.unlink(name)
        os.close(fd)


def _mount_of(path: Path) -> str | None:
    """The id of the mount that holds ``path`` (existing or not); None if unknown.

    Read from ``/proc/self/mountinfo``: the deepest mount point above ``path``'s real
    path (the last one mounted there). A rename works within one mount only.
    """
    import re

    try:
        with open("/proc/self/mountinfo", encoding="utf-8", errors="surrogateescape") as f:
            lines = f.read().splitlines()
    except OSError:
        return None
    real = os.path.realpath(path)
    best, depth = None, -1
    for line in lines:
        fields = line.split()
        if len(fields) < 5:
            continue
        point = re.sub(r"\\([0-7]{3})", lambda m: chr(int(m.group(1), 8)), fields[4])
        inside = real == point or real.startswith(point.rstrip("/") + "/")
        if inside and len(point) >= depth:
            best, depth = fields[0], len(point)
    return best


def cache_root() -> Path:
    """The project's cache folder (not created): kernels, work folders.

    ``$ENERGY_PLANNER_CACHE`` if set, else ``$XDG_CACHE_HOME/energy_planner``, else
    ``~/.cache/energy_planner``.

    Examples
    --------
    >>> import os
    >>> before = os.environ.get("ENERGY_PLANNER_CACHE")
    >>> os.environ["ENERGY_PLANNER_CACHE"] = "/data/cache"
    >>> str(cache_root())
    '/data/cache'
    >>> if before is None:
    ...     del os.environ["ENERGY_PLANNER_CACHE"]
    ... else:
    ...     os.environ["ENERGY_PLANNER_CACHE"] = before
    """
    env = os.environ.get("ENERGY_PLANNER_CACHE")
    if env:
        return Path(env)
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "energy_planner"


def _staging_base(parent: Path) -> Path | None:
    """A folder on ``parent``'s mount, not ``parent``, to build folders in; None if none.

    Tried: the temporary folder (:func:`tempfile.gettempdir`), then ``work`` in the
    project's cache folder (:func:`cache_root`). A folder built there is moved to its
    destination by one rename: nothing is ever beside it.
    """
    mine = _mount_of(parent)
    if mine is None:
        return None
    bases = [Path(tempfile.gettempdir())]
    with contextlib.suppress(RuntimeError, KeyError):  # no home folder
        bases.append(cache_root() / "work")
    for base in bases:
        with contextlib.suppress(OSError, RuntimeError):
            if _mount_of(base) != mine or base.resolve() == parent.resolve():
                continue
            base.mkdir(parents=True, exist_ok=True)
            if os.access(base, os.W_OK | os.X_OK) and _mount_of(base) == mine:
                return base
    return None


@contextlib.contextmanager
def _work_folder(dest: Path, parent: Path) -> Iterator[Path]:
    """An empty folder on ``dest``'s mount to build ``dest`` in (as ``dest.name`` in it).

    A private folder of :func:`_staging_base` when there is one (a kill leaves nothing
    beside ``dest``; the next private folder made there removes it), else a hidden
    ``.<name>.<pid>.<random>.tmp`` beside ``dest`` (the next write to ``dest`` removes it
    after a kill: :func:`remove_stale`). Removed at the end with what it still holds.
    """
    base = _staging_base(parent)
    with contextlib.ExitStack() as stack:
        holder = None
        if base is not None:
            with contextlib.suppress(OSError):  # then beside
                holder = stack.enter_context(_private_dir(base, sweep=True))
        if holder is None:
            holder = stack.enter_context(_holder(dest, parent))
        yield holder


@contextlib.contextmanager
def _atomic_new(dest: Path, parent: Path) -> Iterator[Path]:
    """:func:`atomic_path` with ``create=False``: a fresh name in a private folder."""
    with _work_folder(dest, parent) as holder, _sigterm_raises():
        tmp = holder / dest.name
        try:
            yield tmp
            os.replace(tmp, dest)
        except OSError as exc:
            _reraise(dest, exc)


@contextlib.contextmanager
def _holder(dest: Path, parent: Path) -> Iterator[Path]:
    """A locked temporary folder ``.<name>.<pid>.<random>.tmp`` beside ``dest``, then removed."""
    with contextlib.ExitStack() as stack:
        try:
            prefix = f".{dest.name}.{os.getpid()}."
            holder = stack.enter_context(_locked_folder(parent, prefix, ".tmp"))
        except OSError as exc:
            _reraise(dest, exc)
        yield holder


def _exchange(a: Path, b: Path) -> bool:
    """Swap the paths ``a`` and ``b`` in one step (Linux ``renameat2``); False if unsupported."""
    import sys

    if not sys.platform.startswith("linux"):
        return False
    import ctypes

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):  # pragma: no cover - glibc < 2.28, musl
        return False
    at_fdcwd, rename_exchange = -100, 2
    rc = renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    import errno

    if err in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):  # the file system cannot
        return False
    raise OSError(err, os.strerror(err), str(b))


def folder_entries(path: Path, limit: int = 5) -> tuple[int, list[str]]:
    """The number of entries in folder ``path`` and the first ``limit`` names, sorted."""
    names = sorted(p.name for p in path.iterdir())
    return len(names), names[:limit]


def check_folder_output(dest: str | os.PathLike[str], *, overwrite: bool = False) -> bool:
    """Raise unless ``dest`` may be written as a whole folder; True if it exists.

    The check :func:`atomic_dir` makes, for a command to make before its work: ``dest``
    is new, an empty folder, or a non-empty one to be replaced (``overwrite``). Its
    parent folder is created if missing.

    Raises
    ------
    energy_planner.errors.OutputError
        ``dest`` is a file, a non-empty folder without ``overwrite``, or its parent
        cannot be created.
    """
    from energy_planner.errors import OutputError

    dest = Path(dest)
    _make_parent(dest)
    exists = dest.exists() or dest.is_symlink()
    if exists and not dest.is_dir():
        raise OutputError(
            f"output folder {str(dest)!r} is a file; expected a folder (or a new name)",
            path=str(dest),
            expected="a folder",
        )
    if exists and not overwrite:
        n, first = folder_entries(dest)
        if n:
            raise OutputError(
                f"output folder {str(dest)!r} is not empty ({n} entries: "
                f"{', '.join(first)}{', ...' if n > len(first) else ''}); expected an empty "
                "or new folder: choose another one, or replace it whole with --overwrite "
                "(overwrite=True)",
                path=str(dest),
                value=n,
                expected="an empty or new folder, or --overwrite",
            )
    return exists


@contextlib.contextmanager
def atomic_dir(dest: str | os.PathLike[str], *, overwrite: bool = False) -> Iterator[Path]:
    """Yield an empty temporary folder; it becomes ``dest`` on success.

    For outputs that are a whole folder (a simulated campaign): readers see the previous
    folder or the complete new one, never a mix of old and new files.

    Parameters
    ----------
    dest : str or path-like
        The folder to make. Its parent is created if missing.
    overwrite : bool
        Replace a non-empty ``dest`` whole. Without it a non-empty ``dest`` is refused
        (an empty one is replaced).

    Yields
    ------
    pathlib.Path
        The temporary folder, named ``dest.name``, to be filled: in a private folder on
        ``dest``'s mount (:func:`tempfile.gettempdir` or :func:`cache_root`) when one is
        there, else in a hidden ``.<name>.<pid>.<random>.tmp`` beside ``dest``.

    Raises
    ------
    energy_planner.errors.OutputError
        ``dest`` is not empty (and not ``overwrite``), is a file, or cannot be written.

    Notes
    -----
    On success the folders are swapped in one step (Linux ``renameat2`` with
    ``RENAME_EXCHANGE``) and the old content, now in the temporary folder, is removed.
    Where the file system cannot swap, ``dest`` is moved aside first and then replaced:
    a kill between the two renames leaves no ``dest`` (the old content is in a hidden
    folder beside it). On an exception the temporary folder is removed.

    A SIGKILL leaves ``dest`` as it was, or complete. A folder cannot be unnamed, so the
    one built is somewhere until it is moved in: built in a private folder (the first
    case above) a kill leaves nothing beside ``dest``, and the next folder output made
    by any process removes the private folder (its writer is dead); built beside
    ``dest`` a kill leaves the hidden ``.<name>.<pid>.<random>.tmp`` folder, which the
    next write to ``dest`` removes (:func:`remove_stale`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp()) / "campaign"
    >>> with atomic_dir(d) as tmp:
    ...     _ = (tmp / "a.csv").write_text("old")
    >>> with atomic_dir(d, overwrite=True) as tmp:
    ...     _ = (tmp / "b.csv").write_text("new")
    >>> sorted(p.name for p in d.iterdir()), sorted(p.name for p in d.parent.iterdir())
    (['b.csv'], ['campaign'])
    """
    import shutil

    dest = Path(dest)
    parent = _make_parent(dest)
    remove_stale(dest)
    exists = check_folder_output(dest, overwrite=overwrite)
    with _work_folder(dest, parent) as holder, _sigterm_raises():
        work = holder / dest.name
        try:
            work.mkdir()
        except OSError as exc:
            _reraise(dest, exc)
        yield work
        try:
            if not exists:
                os.rename(work, dest)
            elif not _exchange(work, dest):  # pragma: no cover - no atomic swap here
                aside = Path(
                    tempfile.mkdtemp(
                        dir=parent, prefix=f".{dest.name}.{os.getpid()}.", suffix=".tmp"
                    )
                )
                os.rename(dest, aside / "old")
                os.rename(work, dest)
                shutil.rmtree(aside, ignore_errors=True)
        except OSError as exc:
            _reraise(dest, exc)


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

    Notes
    -----
    ``savefig`` draws a figure that has a layout engine twice: a pass without rendering
    that runs the engine (``layout="constrained"``; the placeholder that
    ``fig.tight_layout()`` leaves runs nothing), then the image. Unless ``bbox_inches``
    is ``"tight"`` (whose bounding box needs that pass), the engine is run here once, at
    the resolution the figure is saved at, as that pass runs it, and set aside while
    saving: the same layout, the image drawn once. The figure gets its engine back (a
    figure changed and saved again is laid out again).
    """
    engine = _lay_out_once(fig, dest, savefig_kw)
    try:
        with atomic_path(dest) as tmp:
            fig.savefig(tmp, **savefig_kw)
    finally:
        if engine is not None:
            fig.set_layout_engine(engine)
    return Path(dest)


def _lay_out_once(fig: Any, dest: str | os.PathLike[str], savefig_kw: Mapping[str, Any]) -> Any:
    """Run ``fig``'s layout engine as ``savefig``'s first pass would, then remove it.

    Returns the engine removed (None: the figure was left as it was).

    Only for matplotlib's own engines, on a figure with axes, saved as PNG (a vector
    format lays out at 72 dpi), without ``bbox_inches`` ``"tight"``, and where removing
    the engine leaves none (rcParams that set a default engine put it back: ``savefig``
    then runs its two passes).
    """
    import matplotlib as mpl
    from matplotlib.layout_engine import (
        ConstrainedLayoutEngine,
        PlaceHolderLayoutEngine,
        TightLayoutEngine,
    )

    engine = getattr(fig, "get_layout_engine", lambda: None)()
    if engine is None or not fig.axes:
        return None
    fmt = (
        savefig_kw.get("format") or Path(dest).suffix.lstrip(".") or mpl.rcParams["savefig.format"]
    )
    if str(fmt).lower() != "png":
        return None
    if type(engine) not in (ConstrainedLayoutEngine, TightLayoutEngine, PlaceHolderLayoutEngine):
        return None
    if mpl.rcParams["figure.autolayout"] or mpl.rcParams["figure.constrained_layout.use"]:
        return None
    bbox = savefig_kw.get("bbox_inches")
    bbox = mpl.rcParams["savefig.bbox"] if bbox is None else bbox
    if isinstance(bbox, str) and bbox == "tight":
        return None
    dpi = savefig_kw.get("dpi")
    dpi = mpl.rcParams["savefig.dpi"] if dpi is None else dpi
    if dpi == "figure":
        dpi = getattr(fig, "_original_dpi", fig.dpi)
    if not isinstance(engine, PlaceHolderLayoutEngine):
        layout_at_dpi(fig, engine, dpi)
    fig.set_layout_engine(None)
    return engine


def layout_at_dpi(fig: Any, engine: Any, dpi: float) -> None:
    """Run the layout ``engine`` on ``fig`` as drawn at ``dpi``, the figure's dpi kept.

    The layout measures the text as a renderer at ``dpi`` draws it, so a figure then
    saved at ``dpi`` is drawn with the text sizes the layout already measured.
    """
    original = fig.dpi
    fig.dpi = dpi
    try:
        engine.execute(fig)
    finally:
        fig.dpi = original


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
