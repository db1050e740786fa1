"""The registry and helpers of ``benchmarks/sweep_bad_inputs.py``.

A case is a small function registered with :func:`case` under a topic. It builds its bad
input in the temporary folder it is given, runs the command line as a user would
(:func:`run`, a subprocess) and returns a :class:`Verdict`: the project's answer (the
first line of the error, or the result) and whether it is *handled*: a clear one-line
error, or a correct result; never a traceback, never a silent wrong number.

Topics live in their own modules, ``benchmarks/_sweep_<topic>.py``; the sweep imports
every such module, so a new topic is a new file (nothing else to edit).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: every registered case, in registration order (topic modules append to it)
CASES: list[Case] = []

#: the checkout whose energy_planner the cases run (``--against`` sets another)
ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Verdict:
    """What the project answered and whether that is handled."""

    answer: str
    handled: bool
    why: str = ""


@dataclass(frozen=True)
class Case:
    """A registered case: ``func(tmp_dir) -> Verdict``."""

    topic: str
    name: str
    what: str
    func: Callable[[Path], Verdict]


def case(topic: str, what: str) -> Callable[[Callable[[Path], Verdict]], Callable[[Path], Verdict]]:
    """Register ``func`` as a case of ``topic``; ``what`` says the bad input in a line."""

    def deco(func: Callable[[Path], Verdict]) -> Callable[[Path], Verdict]:
        CASES.append(Case(topic, func.__name__, what, func))
        return func

    return deco


@dataclass
class Run:
    """One command-line run: exit status, stdout, stderr."""

    args: list[str]
    rc: int
    out: str
    err: str
    data: Any = field(default=None)

    @property
    def traceback(self) -> bool:
        """True if the run printed a Python traceback."""
        return "Traceback (most recent call last)" in self.err + self.out

    @property
    def error(self) -> str:
        """The first ``error:``/``Error:`` line of stderr, else its last line."""
        lines = [ln for ln in self.err.splitlines() if ln.strip()]
        for ln in lines:
            if ln.lower().startswith("error"):
                return ln.strip()
        return lines[-1].strip() if lines else ""

    @property
    def warnings(self) -> list[str]:
        """The ``warning:`` lines of stderr, and the ``notes``/``warnings`` of JSON output."""
        out = [ln.strip() for ln in self.err.splitlines() if ln.startswith("warning:")]
        if isinstance(self.data, dict):
            for key in ("notes", "warnings"):
                items = self.data.get(key) or []
                out += [f"{key[:-1]}: {x}" for x in items if isinstance(x, str)]
        return out


def _command() -> list[str]:
    script = Path(sys.executable).with_name("energy-planner")
    if script.exists():
        return [str(script)]
    return [sys.executable, "-c", "from energy_planner.cli import main; main()"]


def run(tmp: Path, *args: Any, json_out: bool = False, timeout: float = 300) -> Run:
    """Run ``energy-planner ARGS`` in ``tmp`` with the checkout :data:`ROOT` first.

    ``json_out``: add ``--json`` and parse stdout into ``Run.data`` when it is JSON.
    """
    argv = [str(a) for a in args] + (["--json"] if json_out else [])
    env = dict(os.environ, PYTHONPATH=str(ROOT), COLUMNS="200")
    env.pop("ENERGY_PLANNER_MEMORY_CAP", None)
    p = subprocess.run(
        _command() + argv, cwd=tmp, env=env, capture_output=True, text=True, timeout=timeout
    )
    r = Run(argv, p.returncode, p.stdout, p.stderr)
    if json_out and p.returncode == 0:
        try:
            r.data = json.loads(p.stdout)
        except json.JSONDecodeError:
            r.data = None
    return r


def expect_error(r: Run, *needles: str) -> Verdict:
    """Handled: a non-zero exit with a one-line error naming every needle (any case)."""
    if r.traceback:
        return Verdict(r.error or "traceback", False, "traceback")
    if r.rc == 0:
        return Verdict(_summary(r) or "(exit 0)", False, "accepted: expected an error")
    line = r.error
    missing = [n for n in needles if n.lower() not in line.lower()]
    if missing:
        return Verdict(line, False, f"the error does not name {', '.join(missing)}")
    return Verdict(line, True)


def expect_value(
    r: Run, got: float | None, want: float, tol: float, unit: str = "", warn: str | None = None
) -> Verdict:
    """Handled: exit 0 and ``|got - want| <= tol``; with ``warn``, a warning naming it."""
    if r.traceback:
        return Verdict(r.error or "traceback", False, "traceback")
    if r.rc != 0:
        return Verdict(r.error, False, f"refused: expected {want:g}{unit}")
    if got is None:
        return Verdict(_summary(r), False, "no value in the output")
    answer = f"{got:.4g}{unit} (truth {want:.4g}{unit})"
    if warn is not None:
        hits = [w for w in r.warnings if warn.lower() in w.lower()]
        if not hits:
            return Verdict(answer, False, f"no warning naming {warn!r}")
        answer += "; " + hits[0]
    if abs(got - want) > tol:
        return Verdict(answer, False, f"wrong by {got - want:+.3g}{unit} (tolerance {tol:g})")
    return Verdict(answer, True)


def _summary(r: Run) -> str:
    """A result in a line: the numbers of JSON output (``energy_j``, ...), else its first line."""
    if isinstance(r.data, dict):
        nums = [f"{k}={v:.6g}" for k, v in r.data.items() if isinstance(v, int | float)]
        if nums:
            return "exit 0: " + ", ".join(nums[:4])
    return _first_line(r.out)


def _first_line(text: str) -> str:
    return next((ln.strip() for ln in text.splitlines() if ln.strip()), "")
