"""The throughput comparison's particle set is one 3-D lattice in all three codes (ours, LIGGGHTS, YADE)."""

import builtins
import os
import subprocess
import sys
import types

import numpy as np
import pytest

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")


class _Placed(Exception):
    """The YADE script has placed its spheres and is about to simulate."""


class _Yade:
    """Stands in for every YADE name: attributes, calls and sums give another stand-in; ``O.run``
    stops the script (:class:`_Placed`) before it simulates."""

    def __getattr__(self, name):
        if name == "run":
            raise _Placed
        return self

    def __call__(self, *args, **kwargs):
        return self

    def __add__(self, other):
        return self


class _Namespace(dict):
    """The script's module namespace: builtins, then YADE stand-ins for names it does not define;
    what it assigns goes to ``globals_`` too, for its generator expressions."""

    def __init__(self, globals_, **names):
        super().__init__(names)
        self.globals_ = globals_

    def __setitem__(self, name, value):
        super().__setitem__(name, value)
        self.globals_[name] = value

    def __missing__(self, name):
        return getattr(builtins, name) if hasattr(builtins, name) else _Yade()


def yade_spheres(rd, length, monkeypatch):
    """The spheres ((x, y, z), r) that benchmarks/yade_drum_throughput.py gives YADE, without YADE."""
    spheres = []
    monkeypatch.setitem(sys.modules, "yade", types.SimpleNamespace(geom=_Yade()))
    monkeypatch.setattr(sys, "argv", ["yade", repr(rd), repr(length), "0", "0"])
    path = os.path.join(BENCH, "yade_drum_throughput.py")
    globals_ = {"__builtins__": builtins}
    namespace = _Namespace(globals_, sphere=lambda center, radius, **kwargs: spheres.append((*center, radius)))
    with open(path) as f, pytest.raises(_Placed):
        exec(compile(f.read(), path, "exec"), globals_, namespace)
    return np.array(spheres)


def test_liggghts_and_yade_inputs_hold_our_3d_lattice(tmp_path, monkeypatch):
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
    # YADE's script places the same spheres
    yade = yade_spheres(0.04, 0.012, monkeypatch)
    assert len(yade) == len(pos) and np.allclose(yade[:, :3], pos, rtol=0, atol=1e-15) and np.allclose(yade[:, 3], rad)
    # three-dimensional: no two spheres in one axial plane, no overlaps
    assert np.unique(pos[:, 2]).size == len(pos)
    from scipy.spatial import cKDTree

    pairs = cKDTree(pos).query_pairs(2 * rad.max(), output_type="ndarray")
    assert (np.linalg.norm(pos[pairs[:, 0]] - pos[pairs[:, 1]], axis=1) > rad[pairs].sum(axis=1)).all()
