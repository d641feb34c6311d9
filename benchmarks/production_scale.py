"""A production run's way in: LIGGGHTS dumps of 10⁵-10⁶ particles to the first numbers, beside
OVITO and freud on the same files.

Usage::

    python benchmarks/production_scale.py [--sizes 200100x20,1000200x3] [--dir build/production] [--keep]

For each size ``NxF`` (particles × frames) it writes gzip dumps tiled from the LIGGGHTS wet-drum
fixture (``tests/data/liggghts_wet_drum``: its 300 particles and their contacts copied side by
side, ids offset; the fixture's four frames repeated), once, into ``--dir``. Then it times, each
in a fresh process (wall time and peak memory of that process):

- ``granalytics convert`` of the dumps (with the longest silence between two progress updates),
- ``granalytics stats`` of the converted run (every frame identified by GNA),
- their sum: the dumps to the first numbers;
- OVITO (``pip install ovito``) reading the same dumps and clustering every frame with its
  ``ClusterAnalysisModifier`` at the contact cutoff (no cohesion test: a lower bound on the
  work GNA does), and freud (``pip install freud-analysis``) clustering the positions read by
  our reader, when they are installed (the optional extra ``anchors``).
"""

from __future__ import annotations

import argparse
import gzip
import os
import subprocess
import sys
import threading
import time

import numpy as np
import pandas as pd

HERE = os.path.dirname(os.path.abspath(__file__))
FIXTURE = os.path.join(HERE, "..", "tests", "data", "liggghts_wet_drum")
STEPS = (5000, 10000, 15000, 20000)


def _read_block(path):
    with gzip.open(path, "rt") as f:
        lines = f.read().splitlines()
    columns = lines[8].split()[2:]
    table = np.array([[float(x) for x in line.split()] for line in lines[9:]]).reshape(-1, len(columns))
    return lines[:8], columns, table


def write_tiled_dumps(n_tiles, n_frames, folder):
    """Gzip dumps of ``n_tiles`` copies of the fixture side by side over ``n_frames`` frames
    (one file per frame each for particles and contacts). Returns (particle files, contact files)."""
    os.makedirs(folder, exist_ok=True)
    pf, cf = [], []
    for frame in range(n_frames):
        step = STEPS[frame % len(STEPS)]
        out_step = 5000 * (frame + 1)
        pf.append(os.path.join(folder, f"atoms.{out_step}.dump.gz"))
        cf.append(os.path.join(folder, f"pairs.{out_step}.dump.gz"))
        if os.path.exists(pf[-1]) and os.path.exists(cf[-1]):
            continue
        for kind, name, path in (("ATOMS", "atoms", pf[-1]), ("ENTRIES", "pairs", cf[-1])):
            head, columns, table = _read_block(os.path.join(FIXTURE, f"{name}.{step}.dump.gz"))
            side = int(np.ceil(np.sqrt(n_tiles)))
            tiles = np.arange(n_tiles)
            shift = np.column_stack([0.05 * (tiles % side), np.zeros(n_tiles), 0.02 * (tiles // side)])
            big = np.repeat(table[None], n_tiles, axis=0)  # tiles × rows × columns
            if kind == "ATOMS":
                big[:, :, columns.index("id")] += 1000 * tiles[:, None]
                for k, c in enumerate("xyz"):
                    big[:, :, columns.index(c)] += shift[:, None, k]
            else:  # c_cpl[1-6] positions, [7], [8] ids
                for col in (6, 7):
                    big[:, :, col] += 1000 * tiles[:, None]
                for k in range(6):
                    big[:, :, k] += shift[:, None, k % 3]
            big = big.reshape(-1, len(columns))
            frame_table = pd.DataFrame(big, columns=columns)
            int_cols = ["id", "type"] if kind == "ATOMS" else ["c_cpl[7]", "c_cpl[8]", "c_cpl[9]"]
            for c in int_cols:
                frame_table[c] = frame_table[c].astype(np.int64)
            lo = np.array([float(line.split()[0]) for line in head[5:8]])
            hi = np.array([float(line.split()[1]) for line in head[5:8]]) + shift.max(axis=0)
            bounds = "\n".join(f"{a:.6g} {b:.6g}" for a, b in zip(lo, hi))  # the box holds every tile
            header = (f"ITEM: TIMESTEP\n{out_step}\nITEM: NUMBER OF {'ATOMS' if kind == 'ATOMS' else 'ENTRIES'}\n"
                      f"{len(big)}\n{head[4]}\n{bounds}\nITEM: {kind} " + " ".join(columns) + "\n")
            tmp = path + ".tmp"
            with gzip.open(tmp, "wt", compresslevel=1) as f:
                f.write(header)
                frame_table.to_csv(f, sep=" ", header=False, index=False, float_format="%.6g", lineterminator="\n")
            os.replace(tmp, path)
    return pf, cf


def _mapping(folder):
    path = os.path.join(folder, "mapping.toml")
    with open(os.path.join(FIXTURE, "mapping.toml")) as src, open(path, "w") as dst:
        dst.write(src.read())
    return path


def timed(cmd, watch_progress=False):
    """(wall time [s], peak memory [MiB], longest silence on stderr [s]) of ``cmd``, run in a fresh
    process: the peak is the larger of GNU time's -f %M (the largest process's peak resident
    memory) and the sum over the process and its children sampled every 50 ms."""
    start = time.perf_counter()
    proc = subprocess.Popen(["/usr/bin/time", "-f", "PEAK_KB %M", *cmd], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    stamps, chunks = [start], []

    def read_stderr():
        while chunk := proc.stderr.read1(4096) if hasattr(proc.stderr, "read1") else proc.stderr.read(4096):
            stamps.append(time.perf_counter())
            chunks.append(chunk)

    reader = threading.Thread(target=read_stderr)
    reader.start()
    tree_peak = [0]

    def watch_memory():  # the sum over the process and its children (convert's reading worker)
        import psutil

        try:
            root = psutil.Process(proc.pid)
            while proc.poll() is None:
                rss = 0
                for p in [root, *root.children(recursive=True)]:
                    try:
                        rss += p.memory_info().rss
                    except psutil.Error:
                        pass
                tree_peak[0] = max(tree_peak[0], rss)
                time.sleep(0.05)
        except psutil.Error:
            pass

    watcher = threading.Thread(target=watch_memory)
    watcher.start()
    out = proc.stdout.read()
    proc.wait()
    reader.join()
    watcher.join()
    wall = time.perf_counter() - start
    err = b"".join(chunks).decode(errors="replace")
    if proc.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{err[-2000:]}\n{out.decode()[-2000:]}")
    peak = max(int(err.rsplit("PEAK_KB", 1)[1].split()[0]) * 1024, tree_peak[0]) / 2**20  # MiB, all processes
    stamps.append(start + wall)
    silence = float(np.max(np.diff(stamps))) if watch_progress else float("nan")
    return wall, peak, silence


OVITO_SCRIPT = """
import sys, time
from ovito.io import import_file
from ovito.modifiers import ClusterAnalysisModifier
t = time.perf_counter()
pipeline = import_file(sys.argv[1])
pipeline.modifiers.append(ClusterAnalysisModifier(cutoff=float(sys.argv[2]), sort_by_size=True))
n = 0
for frame in range(pipeline.source.num_frames):
    data = pipeline.compute(frame)
    n += data.attributes["ClusterAnalysis.cluster_count"]
print(f"ovito: {pipeline.source.num_frames} frames, {n} clusters in all, {time.perf_counter() - t:.1f} s")
"""

FREUD_SCRIPT = """
import sys, time
import freud, numpy as np
import granalytics as ga
t = time.perf_counter()
n = 0
with ga.open_run(sys.argv[1]) as run:
    for snap in run:
        pos = snap.position - snap.position.mean(axis=0)
        span = np.ptp(pos, axis=0) * 1.2 + 1e-2
        box = freud.box.Box(*span)
        cl = freud.cluster.Cluster()
        cl.compute((box, pos), neighbors={"r_max": float(sys.argv[2])})
        n += cl.num_clusters
print(f"freud: {n} clusters in all, {time.perf_counter() - t:.1f} s")
"""


def _has(module):
    return subprocess.run([sys.executable, "-c", f"import {module}"], capture_output=True).returncode == 0


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="200100x20,1000200x3")
    parser.add_argument("--dir", default="build/production")
    args = parser.parse_args(argv)
    ga_cli = [sys.executable, "-m", "granalytics"]
    cutoff = 2 * 0.75e-3 * 1.05  # touching spheres of the fixture (R = 0.75 mm), 5 % slack
    rows = []
    for size in args.sizes.split(","):
        n, frames = (int(x) for x in size.split("x"))
        folder = os.path.join(args.dir, size)
        t0 = time.perf_counter()
        pf, cf = write_tiled_dumps(n // 300, frames, folder)
        made = time.perf_counter() - t0
        mb = sum(os.path.getsize(p) for p in pf + cf) / 1e6
        print(f"{size}: {len(pf)} + {len(cf)} gzip dumps, {mb:.0f} MB ({made:.0f} s to make or find)", flush=True)
        run = os.path.join(folder, "run.h5")
        convert = timed([*ga_cli, "convert", *pf, "--contacts", *cf, "--mapping", _mapping(folder), "--dt-s", "1e-5",
                         "--out", run, "--overwrite"], watch_progress=True)
        stats = timed([*ga_cli, "stats", run, "--window", "0:1e9", "--quiet", "--out", os.path.join(folder, "ts.csv"), "--overwrite"])
        rows.append((size, "granalytics convert", *convert))
        rows.append((size, "granalytics stats (GNA, every frame)", *stats))
        rows.append((size, "granalytics: dumps to first numbers", convert[0] + stats[0], max(convert[1], stats[1]),
                     float("nan")))
        if _has("ovito"):
            pattern = os.path.join(folder, "atoms.*.dump.gz")
            rows.append((size, "OVITO read + cluster (cutoff)",
                         *timed([sys.executable, "-c", OVITO_SCRIPT, pattern, str(cutoff)])))
        if _has("freud"):
            rows.append((size, "freud cluster (positions from the run file)",
                         *timed([sys.executable, "-c", FREUD_SCRIPT, run, str(cutoff)])))
        for row in rows[-5:]:
            if row[0] == size:
                print(f"  {row[1]:<45} {row[2]:8.1f} s {row[3]:8.0f} MiB  longest silence {row[4]:.1f} s", flush=True)
    print("\n| size | step | wall [s] | peak memory [MiB] | longest silence [s] |\n| --- | --- | --- | --- | --- |")
    for size, step, wall, peak, silence in rows:
        print(f"| {size} | {step} | {wall:.1f} | {peak:.0f} | {'' if np.isnan(silence) else f'{silence:.1f}'} |")


if __name__ == "__main__":
    main()
