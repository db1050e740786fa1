"""The ``energy-planner`` click group: what every command shares.

The package (:mod:`energy_planner.cli`) names the commands and prints the group's own
``--help`` without importing this module (nor click); this module is imported for
everything else. Sub-commands live one per module in the package (``terrain.py``,
``energy.py``, ...), each exposing a click command named ``command``, imported only when
their command runs, so a command's heavy imports (rasterio, ompl, numba) are paid only by
that command.

Two things every command shares are done here, once:

- **Warnings** are collected while the command runs and printed at its end on stderr,
  one line each, ``warning: <message>``, with no line of Python source. A warning that
  repeats (the same text, or the same text but for its numbers, names and paths) is one
  line with its count. A warning carrying a Python remedy
  (:class:`~energy_planner.errors.EnergyPlannerWarning`) is printed without it.
- **Exit status**: 0 success; **2 usage**: the command line is wrong (an unknown or
  missing option, a malformed value, a point outside the map, a channel value the model
  cannot take, a file named on the command line that does not exist or cannot be read);
  **1 data**: a file that is there but whose content is wrong (a DEM that is not a
  raster, a model file that is not JSON, malformed logs, waypoints, keep-outs, sites or
  value tables), or a computation that fails (no path, a fit that cannot be made).
  Commands raise ``click.BadParameter`` or ``click.ClickException`` from the library's
  errors; :func:`exit_status_error` applies the rule above to the error's cause, so a
  command cannot get it wrong. No error prints a traceback.
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import os
import re
import sys
import warnings
from collections.abc import Iterator
from typing import Any

import click

from energy_planner.cli import (
    COMMANDS,
    GROUP_HELP,
    QUIET_HELP,
    _terminal_columns,
    available_commands,
)


class _DataError(click.ClickException):
    """The inputs were read but are wrong, or the computation failed: exit status 1.

    A command-line wrapper of a library error (which carries the project's base): it never
    leaves the command line, so it is private like the other CLI plumbing.
    """

    exit_code = 1


#: What varies between warnings of one kind (quoted names, paths, numbers), a pattern
#: compiled at the first warning (by :mod:`re`'s cache), not by every start of the command.
_VARYING = r"(?i)'[^']*'|\"[^\"]*\"|\S*[/\\]\S*|[-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?%?"


def _warning_text(message: Any) -> str:
    """A warning's text as the command line prints it (no Python-only remedy)."""
    text = message.cli_text() if hasattr(message, "cli_text") else str(message)
    return " ".join(text.split())


class WarningSummary:
    """Warnings of one command, printed at its end: one line per kind, with a count.

    Two warnings are of one kind when their texts are equal but for numbers, quoted
    names and paths (:data:`_VARYING`), e.g. the same note about 90 log files.
    """

    def __init__(self) -> None:
        self.groups: dict[tuple[str, str], list[Any]] = {}

    def add(self, message: Any, category: type[Warning]) -> None:
        """Record one warning (a ``warnings.showwarning`` replacement calls this)."""
        text = _warning_text(message)
        key = (category.__name__, re.sub(_VARYING, "#", text))
        group = self.groups.setdefault(key, [text, 0, set()])
        group[1] += 1
        group[2].add(text)

    def lines(self) -> list[str]:
        """``warning: ...`` lines, one per kind of warning, in the order first seen."""
        out = []
        for text, n, texts in self.groups.values():
            if n == 1:
                out.append(f"warning: {text}")
            elif len(texts) == 1:
                out.append(f"warning: {text} ({n} times)")
            else:
                out.append(f"warning: {text} (and {n - 1} more like it)")
        return out


@contextlib.contextmanager
def summarized_warnings() -> Iterator[WarningSummary]:
    """Collect the warnings raised inside; print them on stderr when the block ends."""
    summary = WarningSummary()

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        summary.add(message, category)

    with warnings.catch_warnings():
        # notes for the developers of the libraries we call, not for the user
        warnings.simplefilter("ignore", DeprecationWarning)
        warnings.simplefilter("ignore", PendingDeprecationWarning)
        warnings.filterwarnings("always", category=UserWarning)  # count every one
        warnings.showwarning = show
        try:
            yield summary
        finally:
            for line in summary.lines():
                click.echo(line, err=True)


def _file_is_there(path: Any) -> bool:
    """True if ``path`` names an existing, readable file or folder."""
    return isinstance(path, str) and os.path.exists(path) and os.access(path, os.R_OK)


#: Library parameters that are files: an error naming one of them (its ``param`` field)
#: is about the file; an error naming another parameter (``band``, ``bounds``, ...) is
#: about that option's value, a usage error even when it names the file too.
FILE_PARAMS = frozenset(
    {"dem", "path", "keep_out", "waypoints", "sites", "model", "logs", "channel", "prior"}
)


def _option_name(exc: click.ClickException) -> str | None:
    """The option a usage error blames, as a parameter name (``--keep-out`` -> keep_out)."""
    param = getattr(exc, "param", None)
    hint = getattr(exc, "param_hint", None) or (None if param is None else param.name)
    if not isinstance(hint, str):
        return None
    return hint.strip("'\"").lstrip("-").replace("-", "_").lower()


def exit_status_error(exc: click.ClickException) -> click.ClickException:
    """``exc`` with the exit status the rule of this module gives its cause.

    A usage error (2) whose cause names a file that is there (its ``path`` field) is
    about the file's content: a :class:`_DataError` (1), unless the error blames an option
    that is not a file (``--start`` outside the map the file covers, ``--band``: the
    error's ``param_hint`` or its cause's ``param`` field). A data error whose cause is a
    file that is not there, or a channel value the model cannot take, is a usage error.
    Anything else is returned as it is.
    """
    from energy_planner.errors import ChannelError, ChannelIOError, EnergyPlannerError

    cause = exc.__cause__
    if not isinstance(cause, EnergyPlannerError):
        return exc
    path = cause.fields.get("path")
    usage = isinstance(exc, click.UsageError)
    option = _option_name(exc)
    other_param = cause.fields.get("param") not in (None, *FILE_PARAMS) or (
        option is not None and option not in FILE_PARAMS
    )
    if usage and path is not None and _file_is_there(path) and not other_param:
        new: click.ClickException = _DataError(exc.format_message())
    elif not usage and path is not None and isinstance(cause, OSError) and not _file_is_there(path):
        new = click.UsageError(exc.format_message())
    elif not usage and isinstance(cause, ChannelError) and not isinstance(cause, ChannelIOError):
        if path is not None and _file_is_there(path):
            return exc  # a value table's content
        new = click.UsageError(exc.format_message())
    else:
        return exc
    new.__cause__ = cause
    return new


class _Context(click.Context):
    """click's context, its help formatter as wide as click's without importing shutil."""

    def make_formatter(self) -> click.HelpFormatter:
        """The help formatter, as wide as click makes it.

        ``terminal_width``, click's ``FORCED_WIDTH`` under its test runner, else the
        terminal's columns, at most ``max_content_width`` (80), less 2, at least 50.
        """
        import click.formatting

        width = self.terminal_width
        if width is None and click.formatting.FORCED_WIDTH is None:
            width = max(min(_terminal_columns(), self.max_content_width or 80) - 2, 50)
        return self.formatter_class(width=width, max_width=self.max_content_width)


class LazyGroup(click.Group):
    """A click group that imports a sub-command's module only when it is used."""

    context_class = _Context

    def list_commands(self, ctx: click.Context) -> list[str]:
        """Return the sorted names of the sub-commands whose modules are installed."""
        return available_commands()

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        """Import and return the sub-command ``cmd_name``, or ``None`` if unavailable."""
        if cmd_name not in available_commands():
            return None
        mod, summary = COMMANDS[cmd_name]
        cmd = importlib.import_module(f"energy_planner.cli.{mod}").command
        cmd.short_help = summary
        return cmd

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """List the commands with their summaries from :data:`COMMANDS`, importing none."""
        rows = [(name, COMMANDS[name][1]) for name in self.list_commands(ctx)]
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)

    def invoke(self, ctx: click.Context) -> Any:
        """Run the sub-command with its warnings summarized and its exit status ruled.

        See the module docstring: warnings become one line per kind on stderr; errors get
        exit status 2 (usage) or 1 (data) by :func:`exit_status_error`, and a library
        error no command caught is a data error, printed without a traceback.
        """
        from energy_planner.errors import EnergyPlannerError

        with summarized_warnings():
            try:
                return super().invoke(ctx)
            except click.ClickException as exc:
                new = exit_status_error(exc)
                if new is exc:
                    raise
                raise new from exc.__cause__
            except EnergyPlannerError as exc:
                err = click.ClickException(str(exc))
                err.__cause__ = exc
                raise exit_status_error(err) from exc


@click.group(
    cls=LazyGroup, help=GROUP_HELP, context_settings={"help_option_names": ["-h", "--help"]}
)
@click.version_option(package_name="energy_planner")
@click.option("-q", "--quiet", is_flag=True, help=QUIET_HELP)
def main(quiet: bool) -> None:
    """Run the group: the ``--quiet`` flag, then the sub-command (help: :data:`GROUP_HELP`)."""
    if quiet or "energy_planner.progress" in sys.modules:  # else its default: not quiet
        from energy_planner.progress import quiet as _quiet

        _quiet(quiet)  # each invocation starts from the flag (a command's own -q may add it)
    _skip_exit_collection()


@functools.cache
def _skip_exit_collection() -> None:
    """At exit, spare the interpreter its last garbage collection (once per process).

    Python's shutdown walks every object the command imported or made (numpy, rasterio,
    the model) for reference cycles: 40-80 ms of CPU on the command's critical path,
    after its result is written, for memory the process frees anyway. ``gc.freeze`` at
    exit moves them out of the collector's reach; files and datasets are closed by their
    context managers before then, and the modules are torn down as before.
    """
    import atexit
    import gc

    atexit.register(gc.freeze)
