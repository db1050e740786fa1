"""Writing ROS 2 bags: messages serialized a block at a time against one by one.

Two measurements, each printing CPU seconds and ratios:

1. One long log (``--samples``, default 100 000: 16.7 min at 100 Hz) with a numeric and a
   text extra channel, written by ``write_rosbag`` in this process: *blocks* (the
   fixed-layout serializer, :mod:`energy_planner.measurements._cdr`) and *messages*
   (``_cdr_layouts`` patched to None: every message built and serialized by rosbags,
   the path ROS 1 bags take), in rounds that alternate which runs first, after one
   untimed write of each. The two bags are compared byte for byte. Also the time of
   ``write_rosbag`` spent outside the serialization (rosbags' writer alone: the same
   bytes handed to ``Writer.write``).
2. With ``--simulate``: ``energy-planner simulate --out DIR --small --bag`` (95 bags)
   as whole processes, CPU of the children (user + system), this checkout
   (``PYTHONPATH``) and, with ``--baseline ROOT``, another checkout, alternately.

Usage::

    python benchmarks/bench_rosbag_write.py [--samples 100000] [--rounds 3] [--version 2]
        [--simulate] [--baseline /work/main]

Measured 2026-11-30 on the shared 2-core machine with other jobs running (load average
3 to 4.8), this checkout the branch a47, baseline main at c537a3b (every message built
and serialized on its own)::

    python benchmarks/bench_rosbag_write.py --rounds 3
    ROS 2: one log of 100000 samples, 5 messages each (500000 messages), 3 rounds
    path          cpu s (median)                           runs
    blocks                  3.43                 3.78 2.97 3.43
    messages               13.03              14.71 13.03 11.84
    messages/blocks CPU ratio: 3.80
    rosbags' writer alone (same bytes, no serialization): 3.95 cpu s
    bags identical (but their names): True

    python benchmarks/bench_rosbag_write.py --rounds 3 --version 1
    ROS 1: ... blocks 3.97 (4.10 3.40 3.97), messages 13.41 (11.98 13.41 16.22)
    messages/blocks CPU ratio: 3.38; bags identical (but their names): True

    python benchmarks/bench_rosbag_write.py --rounds 3 --simulate --baseline /work/main
    (an earlier run: ROS 2 ratio 3.31, blocks 4.30 against 14.24 CPU s)
    simulate --small --bag (95 bags), 3 rounds, cpu s of the process
    this       median   5.34   5.01 5.39 5.34
    baseline   median   7.22   6.91 7.22 7.50
    this/baseline CPU ratio: 0.74

Writing a long log costs 3.3 to 3.8 times less CPU; what is left is rosbags' writer
itself (``Writer.write`` per message, the same as the writer alone given the bytes).
In the simulator's 95 small bags (121 samples, 8 messages each) the per-bag costs of
rosbags' writer weigh more (``close`` and ``add_connection`` dump YAML with ruamel ten
times per bag), so the whole command saves a quarter.
"""

from __future__ import annotations

import argparse
import functools
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from unittest import mock

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import energy_planner.measurements.rosbag as rosbag  # noqa: E402
from energy_planner.measurements import write_rosbag  # noqa: E402


def long_log(n: int, seed: int = 0) -> pd.DataFrame:
    """A log of ``n`` samples at 100 Hz, one numeric and one text extra."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return pd.DataFrame(
        {
            "run": "long",
            "t": 100.0 + 0.01 * np.arange(n),
            "qw": q[:, 0],
            "qx": q[:, 1],
            "qy": q[:, 2],
            "qz": q[:, 3],
            "vx": rng.normal(0.5, 0.1, n),
            "vy": rng.normal(0.0, 0.05, n),
            "wz": rng.normal(0.0, 0.2, n),
            "voltage": rng.uniform(44, 58, n),
            "current": rng.uniform(2, 20, n),
            "x": np.cumsum(rng.normal(0, 0.01, n)),
            "y": np.cumsum(rng.normal(0, 0.01, n)),
            "yaw": rng.uniform(-np.pi, np.pi, n),
            "motor_temp": rng.uniform(20, 80, n),
            "ground": pd.Categorical(rng.choice(["grass", "gravel", "asphalt"], n)),
        }
    )


def cpu_of(fn) -> float:
    t0 = time.process_time()
    fn()
    return time.process_time() - t0


def write(df: pd.DataFrame, out: Path, blocks: bool, version: int = 2) -> None:
    if version == 1:
        out = out.with_suffix(".bag")
    if blocks:
        write_rosbag(df, out, version=version)
    else:
        with mock.patch.object(rosbag, "_layouts", lambda version: None):
            write_rosbag(df, out, version=version)


def writer_alone(out: Path, bag: Path) -> float:
    """CPU s of rosbags' writer given the bytes of ``bag`` (no serialization)."""
    from rosbags.rosbag2 import Reader

    from energy_planner.io.bag import open_writer

    with Reader(bag) as r:
        conns = [(c.topic, c.msgtype, c.msgdef.data, c.digest) for c in r.connections]
        msgs = [(c.topic, ns, bytes(raw)) for c, ns, raw in r.messages()]

    def run():
        with open_writer(out, 2, "mcap") as w:
            cmap = {
                topic: w.add_connection(topic, msgtype, msgdef=msgdef, rihs01=digest)
                for topic, msgtype, msgdef, digest in conns
            }
            for topic, ns, raw in msgs:
                w.write(cmap[topic], ns, raw)

    return cpu_of(run)


def bench_long(n: int, rounds: int, version: int) -> None:
    df = long_log(n)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        write(df, tmp / "warm_b", True, version)
        write(df, tmp / "warm_m", False, version)
        if version == 1:
            blk, msg = tmp / "warm_b.bag", tmp / "warm_m.bag"
        else:
            blk, msg = tmp / "warm_b" / "warm_b.mcap", tmp / "warm_m" / "warm_m.mcap"
        same = blk.read_bytes().replace(b"warm_b", b"") == msg.read_bytes().replace(b"warm_m", b"")
        cpu = {"blocks": [], "messages": []}
        for k in range(rounds):
            order = ("blocks", "messages") if k % 2 == 0 else ("messages", "blocks")
            for name in order:
                run = functools.partial(write, df, tmp / f"{name}{k}", name == "blocks", version)
                cpu[name].append(cpu_of(run))
        alone = writer_alone(tmp / "alone", tmp / "warm_b") if version == 2 else None
    mb = statistics.median(cpu["blocks"])
    mm = statistics.median(cpu["messages"])
    print(
        f"ROS {version}: one log of {n} samples, 5 messages each ({5 * n} messages), "
        f"{rounds} rounds"
    )
    print(f"{'path':12s} {'cpu s (median)':>15s} {'runs':>30s}")
    for name, m in (("blocks", mb), ("messages", mm)):
        runs = " ".join(f"{v:.2f}" for v in cpu[name])
        print(f"{name:12s} {m:15.2f} {runs:>30s}")
    print(f"messages/blocks CPU ratio: {mm / mb:.2f}")
    if alone is not None:
        print(f"rosbags' writer alone (same bytes, no serialization): {alone:.2f} cpu s")
    print(f"bags identical (but their names): {same}")


def child_cpu(cmd: list[str], env: dict, cwd: Path) -> float:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, env=env, cwd=cwd, check=True, capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def bench_simulate(rounds: int, baseline: Path | None) -> None:
    trees = {"this": ROOT}
    if baseline is not None:
        trees["baseline"] = baseline
    exe = [
        sys.executable,
        "-c",
        "import sys; from energy_planner.cli import main; sys.exit(main())",
    ]
    cpu = {k: [] for k in trees}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for k in range(rounds + 1):
            names = list(trees) if k % 2 == 0 else list(trees)[::-1]
            for name in names:
                env = {**os.environ, "PYTHONPATH": str(trees[name])}
                out = tmp / f"{name}{k}"
                c = child_cpu([*exe, "simulate", "--out", str(out), "--small", "--bag"], env, tmp)
                if k:  # the first round warms the page cache and compiled kernels
                    cpu[name].append(c)
    print(f"\nsimulate --small --bag (95 bags), {rounds} rounds, cpu s of the process")
    for name, v in cpu.items():
        print(f"{name:10s} median {statistics.median(v):6.2f}   " + " ".join(f"{x:.2f}" for x in v))
    if baseline is not None:
        r = statistics.median(cpu["this"]) / statistics.median(cpu["baseline"])
        print(f"this/baseline CPU ratio: {r:.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=100_000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--simulate", action="store_true")
    ap.add_argument("--no-long", action="store_true")
    ap.add_argument("--baseline", type=Path)
    ap.add_argument("--version", type=int, choices=(1, 2), default=2)
    a = ap.parse_args()
    if not a.no_long:
        bench_long(a.samples, a.rounds, a.version)
    if a.simulate:
        bench_simulate(a.rounds, a.baseline)


if __name__ == "__main__":
    main()
