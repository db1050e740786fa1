"""Every example in the commands' ``--help`` and in the docs runs as printed.

Examples are the lines that start with ``$ `` (a shell prompt): in each command's help
they stand in an ``Examples:`` block, in README.md and docs/*.md in fenced blocks. Each
source runs in a fresh folder holding ``maps/`` (the bundled maps, as in a checkout),
its lines in order, so a line may use what an earlier line of the same source wrote; a
page's ```python blocks run in that order too (README.md's included: this is where they
run).
The help examples form one tutorial in the order of :data:`HELP_ORDER`; it runs as the
independent chains of :data:`HELP_CHAINS` (each in its own folder, so xdist runs them side
by side), which together cover every example of the tutorial, each chain in its order.

Where a docs block shows what a command prints, every shown line that carries numbers
must be printed too (the line with the same first word), with the same numbers within
:data:`RTOL` (the energy-optimal route's timed refinement can end a little elsewhere on
another machine); ``...`` in a shown line ends what is compared of it.
"""

from __future__ import annotations

import functools
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from energy_planner.cli import COMMANDS, main
from energy_planner.maps import map_path

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: the order the help examples run in: each may use the files earlier ones wrote
HELP_ORDER = [
    "simulate", "fit", "figures", "diagnose", "discover", "terrain", "plan", "energy",
    "compare-routes", "reach", "energy-map", "mission", "follow", "demo",
]  # fmt: skip
#: the tutorial as independent chains: ``(command, i)`` is the command's i-th help example,
#: ``command`` alone all of them. A chain runs in a fresh folder, so it holds every example
#: whose files a later example of it reads (calibration: the campaign and the fitted models,
#: with the planned path that ``energy`` prices by them; missions: the simulated missions).
HELP_CHAINS: dict[str, list[str | tuple[str, int]]] = {
    "calibration": [("simulate", 0), "fit", "figures", "diagnose", "discover", "plan",
                    "energy"],
    "planning": ["terrain", "compare-routes", "reach", "energy-map"],
    "missions": [("simulate", 1), "mission", "follow"],
    "demo": ["demo"],
}  # fmt: skip
#: commands whose examples read nothing but the bundled maps and model: a docs line equal to
#: one of their help examples (comment aside) that shows no output is the same check as the
#: help chain's run of it, so it runs there only (each ``demo`` costs ~10 s of refinement)
SELF_CONTAINED = ("demo",)
#: commands that read only the files their arguments name (and the bundled maps): a line of
#: one of them run again on byte-identical named inputs is the same check, so a worker runs
#: it once and replays its output and its files (:func:`run`). The calibration examples of
#: README.md, docs/*.md and the help's tutorial share their campaigns and fits this way;
#: the sources of no :data:`SHARED_RUNS` group repeat none of them (tested), so they run
#: their lines without keeping them (keeping costs a walk of the folder and a read of the
#: files a line names and writes: 1.4 CPU s of simulate.md's 22)
REPLAYABLE = ("simulate", "fit", "figures", "diagnose", "discover")
#: the pages and help chains that share those runs, by xdist group (a group runs in one
#: worker): the load campaign and its fits; the campaign with a ground effect and a fault
SHARED_RUNS = {"calibration": "load-campaign", "calibration.md": "load-campaign",
               "energy.md": "load-campaign", "README.md": "fault-campaign",
               "diagnosis.md": "fault-campaign"}  # fmt: skip
RTOL = 0.03
NUM = re.compile(r"[-+]?\d+(?:\.\d+)?")


def help_examples(name: str) -> list[str]:
    """The ``$ `` lines of a command's help, as click prints them."""
    from click.testing import CliRunner

    out = CliRunner().invoke(main, [name, "--help"], terminal_width=200).output
    return [ln.strip()[2:] for ln in out.splitlines() if ln.strip().startswith("$ ")]


def doc_examples(path: Path) -> list[tuple[str, str, list[str]]]:
    """A page's examples in order: ``("shell", line, shown)`` for each ``$ `` line of a
    fenced block (with the lines shown after it in that block) and ``("python", code, [])``
    for each ```python block (a later ``$`` line may use the files it writes)."""
    found: list[tuple[str, str, list[str]]] = []
    fence: str | None = None
    shown: list[str] | None = None
    code: list[str] = []
    for line in path.read_text().splitlines():
        if line.startswith("```"):
            if fence is None:
                fence, shown, code = line[3:].strip(), None, []
            else:
                if fence == "python":
                    found.append(("python", "\n".join(code), []))
                fence, shown = None, None
            continue
        if fence is None:
            continue
        if fence == "python":
            code.append(line)
        elif line.startswith("$ "):
            shown = []
            found.append(("shell", line[2:], shown))
        elif shown is not None and line.strip():
            shown.append(line)
    return found


def _workdir(tmp_path: Path) -> Path:
    (tmp_path / "maps").symlink_to(map_path("hill").parent, target_is_directory=True)
    return tmp_path


def run(cmd: str, cwd: Path, replay: bool = True) -> subprocess.CompletedProcess:
    """Run one example line in ``cwd``.

    ``energy-planner ...`` lines run in this process through click's test runner (the
    same entry point, without paying the interpreter's and the kernels' start-up for each
    line); any other line (``printf ... > file``) through bash. With ``replay``, a line of
    a :data:`REPLAYABLE` command is kept and replayed (:func:`_replayed`).
    """
    words = shlex.split(cmd, comments=True)
    if words and words[0] == "energy-planner" and not set(words) & {"|", ">", "<", "&&"}:
        if replay and len(words) > 1 and words[1] in REPLAYABLE:
            return _replayed(words, cwd)
        return _invoke(words, cwd)
    bindir = str(Path(sys.executable).parent)
    env = {**os.environ, "PATH": bindir + os.pathsep + os.environ.get("PATH", "")}
    env["MPLBACKEND"] = "Agg"
    return subprocess.run(
        ["bash", "-c", cmd], cwd=cwd, env=env, capture_output=True, text=True, timeout=600
    )


def _invoke(words: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """``energy-planner WORDS...`` through click's test runner, in ``cwd``."""
    from click.testing import CliRunner

    here = os.getcwd()
    os.chdir(cwd)
    try:
        r = CliRunner().invoke(main, words[1:], env={"MPLBACKEND": "Agg"})
    finally:
        os.chdir(here)
    code = r.exit_code if r.exception is None or isinstance(r.exception, SystemExit) else 1
    err = r.stderr + ("" if code == 0 or r.exception is None else repr(r.exception))
    return subprocess.CompletedProcess(words, code, r.stdout, err)


#: (words, digests of the named inputs) -> (result, files written, paths removed)
_REPLAY: dict[tuple, tuple[subprocess.CompletedProcess, dict[str, bytes], list[str]]] = {}
#: a run that writes more than this is not kept for replay (a full campaign)
REPLAY_MAX_BYTES = 32 * 2**20


def _tree(root: Path) -> dict[str, tuple[int, int]]:
    """``relative path -> (size, mtime_ns)`` of every file under ``root`` (not ``maps/``)."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        if Path(dirpath) == root and "maps" in dirnames:
            dirnames.remove("maps")
        for f in filenames:
            st = os.stat(os.path.join(dirpath, f))
            out[os.path.relpath(os.path.join(dirpath, f), root)] = (st.st_size, st.st_mtime_ns)
    return out


def _digest(path: Path) -> str:
    """The content of a file or of a folder's files, hashed (``-`` if missing)."""
    import hashlib

    if not path.exists():
        return "-"
    h = hashlib.sha1()
    files = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
    for f in files:
        h.update(str(f.relative_to(path)).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


def _replayed(words: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """:func:`_invoke` of a :data:`REPLAYABLE` command, run once per named inputs.

    The key is the command line and the content of every path it names that exists in
    ``cwd`` before the run (the campaign, the model, an ``--out`` folder being replaced).
    A repeat writes the first run's files (and removes what it removed) and returns its
    output, so the page goes on exactly as after a run.
    """
    named = [w.split("=", 1)[-1] for w in words[2:]]
    key = (tuple(words), tuple(_digest(cwd / w) for w in named if w and (cwd / w).exists()))
    if key in _REPLAY:
        r, written, removed = _REPLAY[key]
        for rel in removed:
            (cwd / rel).unlink(missing_ok=True)
        for rel, data in written.items():
            (cwd / rel).parent.mkdir(parents=True, exist_ok=True)
            (cwd / rel).write_bytes(data)
        return r
    before = _tree(cwd)
    r = _invoke(words, cwd)
    after = _tree(cwd)
    changed = [rel for rel, st in after.items() if before.get(rel) != st]
    if sum(after[rel][0] for rel in changed) <= REPLAY_MAX_BYTES:
        written = {rel: (cwd / rel).read_bytes() for rel in changed}
        _REPLAY[key] = (r, written, [rel for rel in before if rel not in after])
    return r


def check_shown(shown: list[str], printed: str, cmd: str) -> None:
    """Each shown line with numbers is printed with the same first word and numbers.

    An indented shown line whose first word starts no printed line is the wrapped tail of
    the line above it (wrapping follows the terminal): skipped.
    """
    lines = printed.splitlines()
    for want in shown:
        head = want.split("...")[0]
        nums = [float(v) for v in NUM.findall(head)]
        words = head.split()
        if not nums or not words or words[0].startswith("Error"):
            continue
        key = words[0]
        cands = [ln for ln in lines if ln.split()[:1] == [key]]
        if not cands and want[:1].isspace():
            continue
        assert cands, f"{cmd!r}: no printed line starts with {key!r} (shown: {want!r})"

        def close(ln: str, nums: list[float] = nums) -> bool:
            got = [float(v) for v in NUM.findall(ln)]
            if len(got) < len(nums):
                return False
            return all(
                abs(a - b) <= RTOL * max(abs(b), 1.0) for a, b in zip(got, nums, strict=False)
            )

        assert any(close(ln) for ln in cands), f"{cmd!r}: shown {want!r}, printed {cands!r}"


@functools.cache
def benchmark_help(script: Path) -> subprocess.CompletedProcess:
    """``python SCRIPT --help``, run once per script (a page names one script many times).

    It runs in this process (a new interpreter would import the library again for each
    script: most of its second): as ``python SCRIPT`` runs it, with the script's folder
    first on ``sys.path`` and ``sys.argv`` ``[SCRIPT, "--help"]``, but under its own module
    name, so that its ``main()`` (the entry point of every benchmark) is called here;
    argparse prints the help and exits. What the script changes of this process (the
    environment, ``sys.path``, ``sys.argv``, warning filters, its own modules and those of
    its folder) is put back; the library's and third parties' modules it imported stay.
    """
    import contextlib
    import importlib.util
    import io
    import warnings

    source = script.read_text()
    if "def main(" not in source or 'if __name__ == "__main__":' not in source:
        return subprocess.run(
            [sys.executable, str(script), "--help"], capture_output=True, text=True, timeout=120
        )
    env, path, argv, modules = dict(os.environ), list(sys.path), sys.argv, set(sys.modules)
    out, err, code = io.StringIO(), io.StringIO(), 0
    try:
        sys.path.insert(0, str(script.parent))
        sys.argv = [str(script), "--help"]
        with warnings.catch_warnings(), contextlib.redirect_stdout(out), \
                contextlib.redirect_stderr(err):  # fmt: skip
            spec = importlib.util.spec_from_file_location(f"_help_{script.stem}", script)
            mod = importlib.util.module_from_spec(spec)
            sys.modules[spec.name] = mod  # its dataclasses look their module up
            spec.loader.exec_module(mod)
            mod.main()
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    except Exception as e:  # as the interpreter would: the error, exit status 1
        code, err = 1, io.StringIO(f"{err.getvalue()}{type(e).__name__}: {e}")
    finally:
        for key in set(os.environ) - set(env):
            del os.environ[key]
        os.environ.update({k: v for k, v in env.items() if os.environ.get(k) != v})
        sys.path[:], sys.argv = path, argv
        for name in set(sys.modules) - modules:
            if Path(getattr(sys.modules[name], "__file__", None) or "/").parent == script.parent:
                del sys.modules[name]
    args = [str(script), "--help"]
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


def check_benchmark(cmd: str) -> None:
    """A ``python benchmarks/X.py ARGS`` line: the script exists and knows every option.

    Benchmarks run at full size for minutes to hours, so the suite does not run them; it
    checks that the line would start as printed (the script's ``--help`` lists each option).
    """
    words = shlex.split(cmd.split("#")[0])
    words = [w for w in words if "=" not in w or w.startswith("-")]  # NUMBA_...=1 prefixes
    assert words[0] == "python" and words[1].startswith("benchmarks/"), cmd
    script = ROOT / words[1]
    assert script.exists(), f"{cmd!r}: no {script}"
    r = benchmark_help(script)
    assert r.returncode == 0, f"{cmd!r}: --help failed\n{r.stderr}"
    for w in words[2:]:
        if w.startswith("--"):
            assert w.split("=")[0] in r.stdout, f"{cmd!r}: {script.name} has no option {w}"


def test_every_command_has_examples():
    """Each command's help shows at least one example, and the tutorial covers them all."""
    assert sorted(HELP_ORDER) == sorted(COMMANDS)
    for name in COMMANDS:
        assert help_examples(name), f"{name} --help has no '$ energy-planner' example"
    from click.testing import CliRunner

    for name in COMMANDS:  # click's no-rewrap marker never shows literally
        out = CliRunner().invoke(main, [name, "--help"]).output
        assert "\\b" not in out and "\b" not in out, name


def checked_by_help_chain(cmd: str) -> bool:
    """True if ``cmd`` is a help example of a :data:`SELF_CONTAINED` command (comment aside):
    :func:`test_help_examples_run_as_printed` runs it, in a folder as fresh as a page's."""
    words = shlex.split(cmd, comments=True)
    if words[:1] != ["energy-planner"] or len(words) < 2 or words[1] not in SELF_CONTAINED:
        return False
    return words in [shlex.split(h) for h in help_examples(words[1])]


def chain_examples(chain: list[str | tuple[str, int]]) -> list[tuple[str, str]]:
    """A chain's ``(command, example line)`` pairs, in the chain's order."""
    out = []
    for step in chain:
        name, i = (step, None) if isinstance(step, str) else step
        lines = help_examples(name)
        out += [(name, cmd) for cmd in (lines if i is None else [lines[i]])]
    return out


def test_help_chains_cover_the_tutorial_in_order():
    """Every help example is in exactly one chain, and each chain keeps the tutorial's order
    (an example runs after the ones before it in the tutorial that its chain holds)."""
    tutorial = [(name, cmd) for name in HELP_ORDER for cmd in help_examples(name)]
    chains = [chain_examples(c) for c in HELP_CHAINS.values()]
    assert sorted(x for c in chains for x in c) == sorted(tutorial)
    assert len({x for c in chains for x in c}) == len(tutorial)  # none twice
    for chain in chains:
        assert chain == [x for x in tutorial if x in chain], chain
    with pytest.raises(IndexError):  # a step naming an example the help does not show
        chain_examples([("simulate", 99)])


def _grouped(names: list, name_of=str) -> list:
    """``names`` as parameters, those of :data:`SHARED_RUNS` in their xdist groups."""
    return [pytest.param(n, marks=pytest.mark.xdist_group(SHARED_RUNS[name_of(n)]))
            if name_of(n) in SHARED_RUNS else n for n in names]  # fmt: skip


@pytest.mark.parametrize("chain", _grouped(list(HELP_CHAINS)))
def test_help_examples_run_as_printed(chain, tmp_path):
    cwd = _workdir(tmp_path)
    for name, cmd in chain_examples(HELP_CHAINS[chain]):
        assert cmd.startswith(f"energy-planner {name}"), cmd
        r = run(cmd, cwd, replay=chain in SHARED_RUNS)
        assert r.returncode == 0, f"{name} --help example {cmd!r}:\n{r.stdout}\n{r.stderr}"


@pytest.mark.parametrize("page", _grouped(DOCS, lambda p: p.name), ids=lambda p: p.name)
def test_doc_examples_run_as_printed(page, tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    examples = doc_examples(page)
    if not examples:
        pytest.skip(f"{page.name} shows no example")
    cwd = _workdir(tmp_path)
    monkeypatch.chdir(cwd)
    namespace: dict = {"__name__": page.stem}  # a page's python blocks share one namespace
    for kind, cmd, shown in examples:
        if kind == "python":
            exec(compile(cmd, str(page), "exec"), namespace)  # noqa: S102
            continue
        if "python benchmarks/" in cmd.split("#")[0]:
            check_benchmark(cmd)
            continue
        if not shown and checked_by_help_chain(cmd):
            continue
        r = run(cmd, cwd, replay=page.name in SHARED_RUNS)
        if any(s.startswith("Error") for s in shown):
            assert r.returncode != 0, f"{page.name}: {cmd!r} should fail as shown"
            first = next(s for s in shown if s.startswith("Error"))
            assert first.split(";")[0][:40] in " ".join(r.stderr.split()), (cmd, r.stderr)
            continue
        assert r.returncode == 0, f"{page.name}: {cmd!r}\n{r.stdout}\n{r.stderr}"
        check_shown(shown, r.stdout + r.stderr, cmd)


def test_shown_lines_are_compared():
    """The comparison itself: a shown number off by more than RTOL fails."""
    check_shown(["energy    100.0 J"], "energy    101.0 J\n", "x")
    with pytest.raises(AssertionError):
        check_shown(["energy    100.0 J"], "energy    110.0 J\n", "x")
    with pytest.raises(AssertionError):
        check_shown(["distance  5 m"], "energy 5 J\n", "x")
    assert shlex.split("a 'b c'") == ["a", "b c"]


def test_pages_reuse_only_help_examples_of_self_contained_commands():
    """A docs line is left to the help chains only when it is one of their examples."""
    assert all(c in HELP_ORDER for c in SELF_CONTAINED)
    assert checked_by_help_chain("energy-planner demo   # a comment")
    assert not checked_by_help_chain("energy-planner demo --max-slope 20")
    assert not checked_by_help_chain("energy-planner plan --dem hill")
    assert any(c in HELP_CHAINS["demo"] for c in SELF_CONTAINED)


def test_only_grouped_sources_repeat_a_replayable_line():
    """A :data:`REPLAYABLE` line run more than once (the same words, in one source or in
    several) is run only by sources of :data:`SHARED_RUNS` groups, the only ones that
    keep their runs for replay: a source of no group runs each of its lines once (a line
    of two groups, as ``discover campaign``, reads a different campaign in each)."""
    sources: dict[tuple[str, ...], list[str]] = {}

    def add(cmd: str, source: str) -> None:
        words = shlex.split(cmd, comments=True)
        if words[:1] == ["energy-planner"] and len(words) > 1 and words[1] in REPLAYABLE:
            sources.setdefault(tuple(words), []).append(source)

    for chain, steps in HELP_CHAINS.items():
        for _, cmd in chain_examples(steps):
            add(cmd, chain)
    for page in DOCS:
        for kind, cmd, _ in doc_examples(page):
            if kind == "shell":
                add(cmd, page.name)
    repeated = {w: s for w, s in sources.items() if len(s) > 1}
    assert repeated  # the calibration examples share their campaigns and fits
    for words, where in repeated.items():
        assert all(s in SHARED_RUNS for s in where), (" ".join(words), where)


def test_a_replayed_run_leaves_what_the_run_left(tmp_path):
    """A repeat of a :data:`REPLAYABLE` line on the same inputs gives the same output and
    the same files (byte for byte); other inputs run it again."""
    cmd = "energy-planner simulate --out tiny --small --noise-free --json"
    for n in "abc":
        (tmp_path / n).mkdir()
    a, b, c = (_workdir(tmp_path / n) for n in "abc")
    first = run(cmd, a)
    (c / "tiny").mkdir()
    (c / "tiny" / "old.csv").write_text("x\n")  # a non-empty --out: refused, not replayed
    assert run(cmd, b) is first
    assert run(cmd, c).returncode != 0 and first.returncode == 0
    files = {p.relative_to(a): p.read_bytes() for p in (a / "tiny").rglob("*") if p.is_file()}
    assert files and files == {
        p.relative_to(b): p.read_bytes() for p in (b / "tiny").rglob("*") if p.is_file()
    }
