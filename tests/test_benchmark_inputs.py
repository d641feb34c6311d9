"""The throughput comparison's particle set is one 3-D lattice in all three codes (ours, LIGGGHTS, YADE)."""

import os
import subprocess
import sys

import numpy as np

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")


def _loop(path):
    text = open(path).read()
    start = text.index("\nrandom.seed(1)")
    return text[start:text.index("row += 1", start)]


def test_liggghts_and_yade_inputs_hold_our_3d_lattice(tmp_path):
    sys.path.insert(0, BENCH)
    try:
        from sim_throughput import drum_lattice
    finally:
        sys.path.remove(BENCH)
    pos, rad = drum_lattice(0.04, 0.012)
    subprocess.run([sys.executable, os.path.join(BENCH, "liggghts_drum", "make_drum.py"), "0.04", "0.012"],
                   cwd=tmp_path, check=True)
    lines = (tmp_path / "drum.data").read_text().split("Atoms\n\n")[1].split("\n")
    atoms = np.array([[float(v) for v in line.split()] for line in lines if line.strip()])
    assert len(atoms) == len(pos) > 2000
    assert np.allclose(atoms[:, 2], 2 * rad, rtol=1e-8) and np.allclose(atoms[:, 4:7], pos, rtol=0, atol=1e-10)
    # YADE's script places the same spheres with the same loop
    assert _loop(os.path.join(BENCH, "yade_drum_throughput.py")) == _loop(os.path.join(BENCH, "liggghts_drum", "make_drum.py"))
    # three-dimensional: no two spheres in one axial plane, no overlaps
    assert np.unique(pos[:, 2]).size == len(pos)
    from scipy.spatial import cKDTree

    pairs = cKDTree(pos).query_pairs(2 * rad.max(), output_type="ndarray")
    assert (np.linalg.norm(pos[pairs[:, 0]] - pos[pairs[:, 1]], axis=1) > rad[pairs].sum(axis=1)).all()
