"""One progress reporter for every long computation (plan, energy map, reach, discover, ...).

Every library function that takes long accepts ``progress=`` and passes it to
:func:`reporter`, which turns it into a :class:`Reporter`:

* ``None`` (the default of most functions): a bar on stderr when stderr is a terminal,
  nothing otherwise;
* ``True``: report on stderr: a bar on a terminal, and in a log (stderr not a terminal)
  one plain line per stage when it has run for :data:`LOG_EVERY_S` seconds, then one
  every :data:`LOG_EVERY_S` seconds and one when it ends: no carriage returns, no bars
  (what the commands pass);
* ``False``: nothing on stderr;
* a callable: called with one :class:`ProgressEvent` at every update, and no bar;
* a :class:`Reporter`: used as is (both a bar and a callback, or a custom subclass).

:func:`quiet` (the command line's ``--quiet``) turns every ``None`` and ``True`` into
``False`` for the rest of the process; callbacks still get their events.

One callback signature for every computation: ``callback(event)``, where the event says
the stage, how far it is (``done`` of ``total`` ``unit``), a message, and a value (the
best energy so far while a planner improves its path).

Examples
--------
>>> events = []
>>> rep = reporter(events.append)
>>> for _ in rep.iterate(range(3), "blocks", unit="block"):
...     pass
>>> [(e.stage, e.done, e.total) for e in events]
[('blocks', 0, 3), ('blocks', 1, 3), ('blocks', 2, 3), ('blocks', 3, 3)]
>>> rep.say("done", stage="energy map")
>>> events[-1].message
'done'
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any, TypeVar

__all__ = ["LOG_EVERY_S", "ProgressEvent", "ProgressLike", "Reporter", "quiet", "reporter",
           "track"]  # fmt: skip

#: In a log (stderr not a terminal), seconds between a running stage's lines
#: (``ENERGY_PLANNER_PROGRESS_EVERY`` sets it; 0 reports every update).
LOG_EVERY_S = float(os.environ.get("ENERGY_PLANNER_PROGRESS_EVERY", "10"))
_QUIET = False


def quiet(on: bool = True) -> None:
    """Silence every reporter made from here on (``--quiet``): no bars, no lines."""
    global _QUIET
    _QUIET = bool(on)


def _is_tty() -> bool:
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # a closed or replaced stderr
        return False


T = TypeVar("T")


@dataclass(frozen=True)
class ProgressEvent:
    """One report of a long computation.

    Attributes
    ----------
    stage : str
        What is running ("heuristic (2-D)", "energy map", "discover", ...).
    done, total : float or None
        How far it is, in ``unit`` (``total`` None when unknown).
    unit : str
        What ``done`` counts (cells, states, blocks, runs, s).
    message : str or None
        A line for people ("step 2 done", "window grown to ...").
    value : float or None
        A number the stage improves (a planner's best energy so far, J).
    elapsed : float
        Seconds since the reporter was made.
    """

    stage: str
    done: float | None = None
    total: float | None = None
    unit: str = ""
    message: str | None = None
    value: float | None = None
    elapsed: float = 0.0


class _Bar:
    """One stage of a :class:`Reporter`: a tqdm bar and/or callback events."""

    def __init__(self, rep: Reporter, stage: str, total: float | None, unit: str, fmt: str | None):
        self.rep, self.stage, self.total, self.unit = rep, stage, total, unit
        self.done: float = 0
        self.value: float | None = None
        self.tqdm = None
        self.logged = self.t0 = time.perf_counter()
        self.log = rep.show is True and not _is_tty()  # plain lines in a log
        if rep.show is not False and not self.log:
            from tqdm import tqdm

            kw: dict[str, Any] = {"bar_format": fmt} if fmt else {}
            self.tqdm = tqdm(
                total=total, desc=stage, unit=unit, file=sys.stderr, leave=False,
                disable=None, **kw,
            )  # fmt: skip
        self._emit()

    def _line(self, final: bool = False) -> None:
        """In a log: a line once the stage has run LOG_EVERY_S, then every LOG_EVERY_S."""
        if not self.log:
            return
        now = time.perf_counter()
        if final:
            if now - self.t0 < LOG_EVERY_S:
                return  # a short stage leaves no line
        elif now - self.logged < LOG_EVERY_S:
            return
        self.logged = now
        unit = f" {self.unit}" if self.unit else ""
        if self.total:
            share = 100 * min(self.done / self.total, 1)
            how = f"{share:.0f}% ({self.done:g}/{self.total:g}{unit})"
        else:
            how = f"{self.done:g}{unit}"
        best = f", best {self.value:.6g}" if self.value is not None else ""
        what = "done" if final else "running"
        print(f"{self.stage}: {what}, {how}{best}, {now - self.t0:.1f} s", file=sys.stderr,
              flush=True)  # fmt: skip

    def _emit(self, message: str | None = None) -> None:
        self._line()
        if self.rep.callback is not None:
            self.rep.callback(
                ProgressEvent(self.stage, self.done, self.total, self.unit, message,
                              self.value, self.rep.elapsed())
            )  # fmt: skip

    def update(self, n: float = 1) -> None:
        """``n`` more units done."""
        self.done += n
        if self.tqdm is not None:
            self.tqdm.update(n)
        self._emit()

    def set(self, done: float, value: float | None = None, postfix: str | None = None) -> None:
        """Set how far the stage is (and the value it improves)."""
        self.done = done
        self.value = value if value is not None else self.value
        if self.tqdm is not None:
            self.tqdm.n = done if self.total is None else min(done, self.total)
            if postfix is not None:
                self.tqdm.set_postfix_str(postfix, refresh=False)
            self.tqdm.refresh()
        self._emit()

    def close(self) -> None:
        """End the stage (the bar is removed from the terminal; a log gets its last line)."""
        if self.log:
            self._line(final=True)
            self.log = False
        if self.tqdm is not None:
            self.tqdm.close()
            self.tqdm = None

    def __enter__(self) -> _Bar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class Reporter:
    """Where a long computation reports: a bar on stderr and/or a callback.

    Parameters
    ----------
    show : bool or None
        True: bars on a terminal, plain lines every :data:`LOG_EVERY_S` in a log; None:
        bars only on a terminal; False: nothing on stderr (also after :func:`quiet`).
    callback : callable, optional
        ``callback(event: ProgressEvent)`` at every update.
    """

    def __init__(
        self, show: bool | None = None, callback: Callable[[ProgressEvent], None] | None = None
    ) -> None:
        self.show = False if _QUIET else show
        self.callback = callback
        self.t0 = time.perf_counter()

    def elapsed(self) -> float:
        """Seconds since this reporter was made."""
        return time.perf_counter() - self.t0

    def bar(
        self, stage: str, total: float | None = None, unit: str = "it", fmt: str | None = None
    ) -> _Bar:
        """Start a stage; use as a context manager, with ``update`` / ``set``."""
        return _Bar(self, stage, total, unit, fmt)

    def iterate(
        self, iterable: Iterable[T], stage: str, total: int | None = None, unit: str = "it"
    ) -> Iterator[T]:
        """Yield from ``iterable``, reporting one unit per item."""
        if total is None and hasattr(iterable, "__len__"):
            total = len(iterable)  # type: ignore[arg-type]
        with self.bar(stage, total, unit) as b:
            for item in iterable:
                yield item
                b.update(1)

    def say(self, message: str, stage: str = "") -> None:
        """A line for people: on stderr (when shown) and to the callback."""
        if self.show or (self.show is None and _is_tty()):
            prefix = f"{stage}: " if stage else ""
            print(f"{prefix}{message}", file=sys.stderr, flush=True)
        if self.callback is not None:
            self.callback(ProgressEvent(stage, message=message, elapsed=self.elapsed()))


#: What ``progress=`` accepts everywhere.
ProgressLike = bool | None | Callable[[ProgressEvent], None] | Reporter


def reporter(progress: ProgressLike = None) -> Reporter:
    """The :class:`Reporter` for a ``progress=`` argument (see the module docstring)."""
    if isinstance(progress, Reporter):
        return progress
    if progress is None or isinstance(progress, bool):
        return Reporter(show=False if _QUIET else progress)
    if callable(progress):
        return Reporter(show=False, callback=progress)
    raise TypeError(
        f"progress={progress!r}: expected True, False, None, a callable taking a "
        "ProgressEvent, or a Reporter"
    )


def track(
    iterable: Iterable[T],
    stage: str,
    progress: ProgressLike = None,
    total: int | None = None,
    unit: str = "it",
) -> Iterable[T]:
    """``iterable`` reported on the reporter of ``progress`` (as is when it is False)."""
    if progress is False:
        return iterable
    return reporter(progress).iterate(iterable, stage, total, unit)
