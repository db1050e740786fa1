"""The ``energy-planner`` command line.

A click group (:mod:`energy_planner.cli._group`: the warnings and exit statuses every
command shares) whose sub-commands live one per module in this package (``terrain.py``,
``energy.py``, ...), each exposing a click command named ``command``. Modules are
imported only when their command runs, so a command's heavy imports (rasterio, ompl,
numba) are paid only by that command.

This module itself imports neither click nor the group: ``energy-planner --help`` (the
console script's :data:`main` called with ``--help`` or ``-h`` alone) prints the group's
help from :data:`COMMANDS`, :data:`GROUP_HELP` and :data:`GROUP_OPTIONS`, wrapped as
click wraps it (:func:`group_help`), in the time of the interpreter's own start-up and
:mod:`textwrap`. Anything else, and every use of :data:`main` as a click group
(``CliRunner().invoke(main, ...)``, ``main.get_command``), loads the group first.
The names of :mod:`energy_planner.cli._group` (``exit_status_error``,
``summarized_warnings``, ...) are importable from here too, loading it.
"""

from __future__ import annotations

import os
import sys

# one BLAS thread, set before any command imports numpy (which loads OpenBLAS): the
# commands' linear algebra is small (a fold's fit: tens of terms over hundreds of windows),
# and OpenBLAS's threads cost more than they give there, spinning against each other and
# any other work: diagnose on the small simulated campaign took 14.8 instead of 20.9 CPU s
# of a busy 2-core machine, discover 16.2 instead of 22.5, the printed numbers identical.
# Set the variable to use more.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

# command name -> (module in energy_planner.cli, one-line summary for the command list).
# The summaries live here so that ``energy-planner --help`` lists the commands without
# importing them (numpy, pandas and numba stay unloaded); a command's own ``--help``
# shows its docstring.
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("demo", "Fig. 1 on the bundled hill: direct, shortest, optimal route."),
    "terrain": ("terrain", "Summarize a DEM; write slope and aspect rasters."),
    "energy": ("energy", "Energy of walking given waypoints over a DEM, per segment."),
    "energy-map": ("energy_map", "Heading-dependent energy map of a DEM (J/m per heading)."),
    "simulate": ("simulate", "Simulate a campaign or missions from mechanistic physics."),
    "fit": ("fit", "Fit the energy model of your robot from its logs."),
    "figures": ("figures", "The paper's Fig. 3, 4 and 5 from logs, as PNGs."),
    "diagnose": ("diagnose", "Compare a model with logs and rank the missing effects."),
    "discover": ("discover", "Find and add the effects the base model misses."),
    "plan": ("plan", "Plan an energy-minimal path on SE(2) from a start to a goal."),
    "compare-routes": ("compare_routes", "Direct line vs shortest vs energy-optimal route."),
    "reach": ("reach", "Least energy to every cell; the area a battery reaches."),
    "mission": ("mission", "Visit several sites in the least-energy order, legs planned."),
    "follow": ("follow", "Replay a log along a planned path: remaining energy, updated."),
}

#: The group's help text (click's ``help`` of the group).
GROUP_HELP = (
    "Plan energy-minimal routes for legged robots on sloping ground.\n\n"
    "Start with `energy-planner demo`."
)
#: The help of the group's ``-q/--quiet`` flag.
QUIET_HELP = (
    "No progress on stderr (bars on a terminal, a line every 10 s in a log); warnings "
    "and errors are still printed. Results go to stdout either way."
)
#: The group's options as its ``--help`` lists them, in click's order: ``--version``
#: (``click.version_option``), ``-q/--quiet``, then the help option (texts as click's).
GROUP_OPTIONS: tuple[tuple[str, str], ...] = (
    ("--version", "Show the version and exit."),
    ("-q, --quiet", QUIET_HELP),
    ("-h, --help", "Show this message and exit."),
)
#: The group's usage after the program's name (click's ``[OPTIONS]`` and
#: ``subcommand_metavar``).
GROUP_USAGE = "[OPTIONS] COMMAND [ARGS]..."


def _terminal_columns() -> int:
    """Columns of the terminal as :func:`shutil.get_terminal_size` gives them, without it.

    ``COLUMNS`` when set, else the width of stdout's terminal, else 80. (Importing
    :mod:`shutil` imports the bz2, lzma and zlib modules: a few ms of ``--help``.)
    """
    try:
        columns = int(os.environ["COLUMNS"])
    except (KeyError, ValueError):
        columns = 0
    if columns <= 0:
        try:
            columns = os.get_terminal_size(sys.__stdout__.fileno()).columns
        except (AttributeError, ValueError, OSError):
            columns = 0
    return columns if columns > 0 else 80


def help_width() -> int:
    """The width of the help text, as click's formatter takes it outside its test runner.

    The terminal's columns, at most 80, less 2, at least 50.
    """
    return max(min(_terminal_columns(), 80) - 2, 50)


def _command_modules() -> set[str]:
    """Names of the modules of this package's folder(s), listed once (no import search)."""
    names: set[str] = set()
    for folder in __path__:
        try:
            names.update(f.split(".", 1)[0] for f in os.listdir(folder))
        except OSError:  # not a folder (a zip): ask the import system
            import importlib.util

            return {
                mod
                for mod, _ in COMMANDS.values()
                if importlib.util.find_spec(f"energy_planner.cli.{mod}") is not None
            }
    return names


def available_commands() -> list[str]:
    """Sorted names of the sub-commands whose modules are installed."""
    there = _command_modules()
    return sorted(name for name, (mod, _) in COMMANDS.items() if mod in there)


def group_help(prog: str, width: int) -> str:
    """The group's ``--help`` text for program name ``prog``, ``width`` columns wide.

    The text click's ``main.get_help`` gives (``tests/test_install.py`` compares the two
    over widths and program names): click's usage line, its help text and its definition
    lists (a first column at most 30 wide plus 2, the second wrapped to the rest), with
    :class:`textwrap.TextWrapper` as click's ``wrap_text`` configures it. Click's own
    wrapper differs from textwrap's only in words longer than a line, which none of
    these texts has at 50 columns or more; its English texts are untranslated (click
    ships no message catalogs).
    """
    import textwrap

    def fill(text: str, width: int, first: str = "", rest: str = "") -> str:
        wrapper = textwrap.TextWrapper(
            width, initial_indent=first, subsequent_indent=rest, replace_whitespace=False
        )
        return wrapper.fill(text.expandtabs())

    def dl(rows: list[tuple[str, str]]) -> list[str]:
        first_col = min(max(len(a) for a, _ in rows), 30) + 2
        text_width = max(width - first_col - 2, 10)
        out = []
        for a, b in rows:
            head = f"  {a}"
            if len(a) <= first_col - 2:
                head += " " * (first_col - len(a))
            else:
                head += "\n" + " " * (first_col + 2)
            lines = fill(b, text_width).splitlines() or [""]
            out.append(head + lines[0] + "\n")
            out += [" " * (first_col + 2) + line + "\n" for line in lines[1:]]
        return out

    prefix = f"Usage: {prog} "
    if width >= len(prefix) + 20:
        usage = fill(GROUP_USAGE, width, prefix, " " * len(prefix))
    else:
        usage = prefix + "\n" + fill(GROUP_USAGE, width, " " * 11, " " * 11)
    text = "\n\n".join(fill(p, width, "  ", "  ") for p in GROUP_HELP.split("\n\n"))
    parts = [usage, "\n", "\n", text, "\n", "\n", "Options:\n", *dl(list(GROUP_OPTIONS))]
    commands = [(name, COMMANDS[name][1]) for name in available_commands()]
    if commands:
        parts += ["\n", "Commands:\n", *dl(commands)]
    return "".join(parts).rstrip("\n")


def _program_name() -> str | None:
    """The program name click gives the console script (its file's name).

    None when click would name a ``python -m`` run (from the module: click prints that
    help).
    """
    main_module = sys.modules.get("__main__")
    if getattr(main_module, "__package__", None) not in (None, ""):
        return None
    return os.path.basename(sys.argv[0])


def _print_group_help() -> None:
    """Print the group's help and exit 0 when the command line is ``--help`` or ``-h``.

    As click would (its shell-completion variable unset): on stdout, then exit status 0;
    a closed pipe exits with status 1 and no traceback. Returns, printing nothing, on any
    other command line.
    """
    if sys.argv[1:] not in (["--help"], ["-h"]) or sys.stdout is None:
        return
    prog = _program_name()
    if prog is None:
        return
    complete = prog.replace("-", "_").replace(".", "_")
    if os.environ.get(f"_{complete}_COMPLETE".upper()):
        return
    text = group_help(prog, help_width())
    try:
        sys.stdout.write(text + "\n")
        sys.stdout.flush()
    except UnicodeEncodeError:  # a program name stdout cannot encode: click's echo can
        return
    except BrokenPipeError:
        from click.utils import _PacifyFlushWrapper

        sys.stdout = _PacifyFlushWrapper(sys.stdout)
        sys.stderr = _PacifyFlushWrapper(sys.stderr)
        sys.exit(1)
    sys.exit(0)


def _lazy_binding() -> None:
    """Load the command's extension modules with lazy symbol binding (``RTLD_LAZY``).

    Python's default (``RTLD_NOW``) resolves every symbol of a shared library when it
    loads: rasterio's GDAL, PROJ, GEOS, HDF5 and netCDF export tens of thousands that a
    command never calls, and resolving them was ~37 M of the ~1000 M instructions of a
    warm ``energy`` on the bundled hill (3.6 %). Lazily, a function's symbol is resolved
    at its first call, as in any C program; a library that lacks one fails at that call
    instead of at import. Only the console script's process (not a Python caller's);
    ``LD_BIND_NOW=1`` in the environment still binds everything at load.
    """
    if hasattr(os, "RTLD_LAZY") and hasattr(sys, "setdlopenflags"):
        sys.setdlopenflags(sys.getdlopenflags() & ~os.RTLD_NOW | os.RTLD_LAZY)


def _load_group() -> object:
    """The click group (:data:`energy_planner.cli._group.main`), imported on first use."""
    from energy_planner.cli._group import main as group

    return group


class _Main:
    """:data:`main`: the click group, loaded on first use, and the console script's entry.

    Called with no arguments (as the console script calls it), a bare ``--help`` or
    ``-h`` prints the group's help without loading click (:func:`_print_group_help`).
    Everything else is the group's: calls, attributes (``main.main``, ``main.name``,
    ``main.get_command``) and ``isinstance(main, click.Group)``.
    """

    __slots__ = ()

    @property  # type: ignore[misc]
    def __class__(self) -> type:  # isinstance(main, click.Group) sees the group's class
        return type(_load_group())

    def __call__(self, *args: object, **kwargs: object) -> object:
        if not args and not kwargs:
            _print_group_help()
            _lazy_binding()
        return _load_group()(*args, **kwargs)

    def __getattr__(self, name: str) -> object:
        return getattr(_load_group(), name)

    def __setattr__(self, name: str, value: object) -> None:
        setattr(_load_group(), name, value)

    def __delattr__(self, name: str) -> None:
        delattr(_load_group(), name)

    def __repr__(self) -> str:
        return repr(_load_group())


#: The ``energy-planner`` command (the console script's ``energy_planner.cli:main``).
main = _Main()

#: Names defined by :mod:`energy_planner.cli._group`, importable from here.
_GROUP_NAMES = frozenset(
    {
        "FILE_PARAMS",
        "LazyGroup",
        "WarningSummary",
        "exit_status_error",
        "summarized_warnings",
        "_Context",
        "_DataError",
    }
)


def __getattr__(name: str) -> object:
    if name not in _GROUP_NAMES:
        raise AttributeError(f"module 'energy_planner.cli' has no attribute {name!r}")
    from energy_planner.cli import _group as group_module

    return getattr(group_module, name)
