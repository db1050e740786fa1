"""Bad inputs as users bring them: a clear error or a correct result for every one.

Usage::

    python benchmarks/sweep_bad_inputs.py [--topic rasters] [-k NAME] [--against DIR] [--json]

Each case builds one bad input in a temporary folder (a DEM as GIS tools write them, ...),
runs the command line on it as a user would (a subprocess) and prints the case, the
project's answer (the first line of the error, or the result against the truth) and a
verdict: ``handled`` is a clear one-line error or a correct result; ``WRONG`` is a
traceback, a silent wrong number or an error that names the wrong cause. The exit status
is 1 if any case is not handled.

``--against DIR`` runs every case a second time with the ``energy_planner`` of another
checkout (e.g. ``--against /path/to/main``) and prints both verdicts side by side: the
baseline.

Cases live in ``benchmarks/_sweep_<topic>.py`` (one file per topic, each registering its
cases with ``_sweep.case``); this script imports them all.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _sweep  # noqa: E402


def _load_topics() -> None:
    for f in sorted(Path(__file__).resolve().parent.glob("_sweep_*.py")):
        importlib.import_module(f.stem)


def _run_case(c: _sweep.Case) -> _sweep.Verdict:
    with tempfile.TemporaryDirectory(prefix=f"sweep_{c.name}_") as tmp:
        try:
            return c.func(Path(tmp))
        except Exception as exc:  # noqa: BLE001 - a broken case is reported, not raised
            return _sweep.Verdict(f"case failed: {type(exc).__name__}: {exc}", False, "case")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--topic", help="run only this topic")
    ap.add_argument("-k", dest="select", help="run only cases whose name contains this")
    ap.add_argument("--against", type=Path, help="baseline: another checkout's root folder")
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    args = ap.parse_args(argv)
    _load_topics()
    cases = [
        c
        for c in _sweep.CASES
        if (args.topic is None or c.topic == args.topic)
        and (args.select is None or args.select in c.name)
    ]
    roots = [("this", _sweep.ROOT)]
    if args.against is not None:
        roots.append(("baseline", args.against.resolve()))
    rows = []
    t0 = time.perf_counter()
    for c in cases:
        row = {"topic": c.topic, "case": c.name, "input": c.what}
        for label, root in roots:
            _sweep.ROOT = root
            v = _run_case(c)
            row[label] = {"handled": v.handled, "answer": v.answer, "why": v.why}
        _sweep.ROOT = roots[0][1]
        rows.append(row)
        if not args.json:
            _print_row(row, [r[0] for r in roots])
    handled = sum(r["this"]["handled"] for r in rows)
    if args.json:
        print(json.dumps({"cases": rows, "handled": handled, "total": len(rows)}, indent=2))
    else:
        line = f"\n{handled} of {len(rows)} cases handled"
        if args.against is not None:
            base = sum(r["baseline"]["handled"] for r in rows)
            line += f" (baseline {args.against}: {base} of {len(rows)})"
        print(line + f"; {time.perf_counter() - t0:.0f} s")
        print("command: python benchmarks/sweep_bad_inputs.py " + " ".join(sys.argv[1:]))
    return 0 if handled == len(rows) else 1


def _print_row(row: dict, labels: list[str]) -> None:
    print(f"[{row['topic']}] {row['case']}: {row['input']}")
    for label in labels:
        v = row[label]
        mark = "handled" if v["handled"] else "WRONG  "
        why = f"  <- {v['why']}" if v["why"] else ""
        tag = f"{label:>8} " if len(labels) > 1 else "  "
        print(f"  {tag}{mark} {v['answer'][:160]}{why}")


if __name__ == "__main__":
    sys.exit(main())
