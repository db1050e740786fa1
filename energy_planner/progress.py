"""One progress reporter for every long computation (plan, energy map, reach, discover, ...).

Every library function that takes long accepts ``progress=`` and passes it to
:func:`reporter`, which turns it into a :class:`Reporter`:

* ``None`` (the default of most functions): a bar on stderr when stderr is a terminal;
* ``True`` / ``False``: a bar on stderr always (unless it is not a terminal: tqdm's own
  rule, so logs and CI output stay clean) / never;
* a callable: called with one :class:`ProgressEvent` at every update, and no bar;
* a :class:`Reporter`: used as is (both a bar and a callback, or a custom subclass).

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

import sys
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any, TypeVar

__all__ = ["ProgressEvent", "ProgressLike", "Reporter", "reporter", "track"]

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
        if rep.show is not False:
            from tqdm import tqdm

            kw: dict[str, Any] = {"bar_format": fmt} if fmt else {}
            self.tqdm = tqdm(
                total=total, desc=stage, unit=unit, file=sys.stderr, leave=False,
                disable=None, **kw,
            )  # fmt: skip
        self._emit()

    def _emit(self, message: str | None = None) -> None:
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
        """End the stage (the bar is removed from the terminal)."""
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
        Draw bars and print messages on stderr: True, False, or None (only when stderr
        is a terminal).
    callback : callable, optional
        ``callback(event: ProgressEvent)`` at every update.
    """

    def __init__(
        self, show: bool | None = None, callback: Callable[[ProgressEvent], None] | None = None
    ) -> None:
        self.show = show
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
        if self.show or (self.show is None and sys.stderr.isatty()):
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
        return Reporter(show=progress)
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
