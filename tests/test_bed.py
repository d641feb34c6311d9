"""Three-dimensional beds: the bed measures, the simulator's 3-D insertion and its settled-bed guard,
and the warning of ``granalytics info`` on a planar drum run."""

import dataclasses
import math

import numpy as np
import pytest

import granalytics as ga
from granalytics import RunWriter, Snapshot, bed_structure
from granalytics.cli import main as cli_main
from granalytics.datasets.synthetic import synthetic_meta
from sim.packing import insertion_positions
from sim.run import Simulation

from test_sim_run import ORIGINAL, SMALL


def _touching_snapshot(position, radius, velocity=None, meta=None):
    """A frame whose contacts are every pair closer than 1.001 (R_i + R_j) (gap from the positions)."""
    from scipy.spatial import cKDTree

    n = len(radius)
    pairs = cKDTree(position).query_pairs(2.002 * radius.max(), output_type="ndarray")
    gap = np.linalg.norm(position[pairs[:, 1]] - position[pairs[:, 0]], axis=1) - radius[pairs].sum(axis=1)
    keep = gap < 0.001 * radius.max()
    pairs, gap = pairs[keep], gap[keep] - 0.001 * radius.max()  # touching: a small overlap
    m = len(pairs)
    return Snapshot(time=0.0, step=0, ids=np.arange(n), radius=radius, position=position,
                    velocity=np.zeros((n, 3)) if velocity is None else velocity, angular_velocity=np.zeros((n, 3)),
                    film_volume=np.zeros(n), contact_i=pairs[:, 0], contact_j=pairs[:, 1], f_cap=np.zeros(m),
                    f_normal=np.zeros(m), gap=gap, bridge_volume=np.zeros(m), meta=meta)


def _planar_snapshot(meta=None):
    """Discs on a square lattice in three axial layers farther apart than a diameter (a planar bed)."""
    r = 1e-3
    g = np.arange(6) * 2 * r
    x, y, z = np.meshgrid(g, g, np.arange(3) * 2.1 * r, indexing="ij")
    pos = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    rng = np.random.default_rng(1)
    vel = np.column_stack([rng.normal(size=(len(pos), 2)), np.zeros(len(pos))])
    return _touching_snapshot(pos, np.full(len(pos), r), vel, meta)


def _fcc_snapshot(meta=None):
    """A face-centred cubic crystal: contacts along the 12 ⟨110⟩ directions, 8 of them with |n_z| = 1/√2."""
    r = 1e-3
    a = 2 * math.sqrt(2) * r
    cells = np.stack(np.meshgrid(*[np.arange(4)] * 3, indexing="ij"), -1).reshape(-1, 3)
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    pos = (cells[:, None, :] + basis[None]).reshape(-1, 3) * a
    return _touching_snapshot(pos, np.full(len(pos), r), meta=meta)


def test_bed_structure_tells_a_planar_bed_from_a_3d_one():
    planar = bed_structure(_planar_snapshot())
    assert planar.n_touching > 0 and planar.crossing_fraction == 0.0 and planar.axial_fabric == 0.0
    assert planar.axial_speed_ratio == 0.0 and planar.axial_layers == 3 and planar.planar
    fcc = bed_structure(_fcc_snapshot())
    assert fcc.crossing_fraction == pytest.approx(8 / 12, abs=0.02)  # ⟨110⟩ directions with a z component
    assert fcc.axial_fabric == pytest.approx(1 / 3, abs=0.02)  # a cubic crystal's fabric is isotropic
    interior = 12 * (2 * 2 * 2) * 4  # at least: the bulk sites of the 4x4x4 cells have 12 contacts
    assert fcc.n_touching > interior / 2 and not fcc.planar
    assert 2 * fcc.n_touching / fcc.n_particles == pytest.approx(fcc.coordination)
    with pytest.raises(ga.ParameterError, match="axis"):
        bed_structure(_fcc_snapshot(), axis=3)
    with pytest.raises(ga.ParameterError, match="Snapshot"):
        bed_structure("run.h5")


def test_insertion_is_three_dimensional_without_overlaps():
    p = SMALL
    rng = np.random.default_rng(0)
    radius = p.r_mean * rng.uniform(1 - p.d_spread, 1 + p.d_spread, p.n_particles)
    pos = insertion_positions(p, radius, rng)
    from scipy.spatial.distance import pdist, squareform

    dist = squareform(pdist(pos)) + np.eye(len(pos))
    assert (dist - radius[:, None] - radius[None, :] > 0).all()  # no overlaps
    assert (np.hypot(pos[:, 0], pos[:, 1]) + radius < p.drum_radius).all()
    assert (pos[:, 2] - radius > 0).all() and (pos[:, 2] + radius < p.drum_length).all()
    assert np.unique(pos[:, 2]).size == len(pos)  # no two particles share an axial plane
    # nearest neighbours lie on cube diagonals: most of them across axial layers
    nearest = np.argmin(dist, axis=1)
    n = pos[nearest] - pos
    assert np.mean(np.abs(n[:, 2]) / np.linalg.norm(n, axis=1) > 0.1) > 0.5


@pytest.fixture(scope="module")
def settled_3d():
    sim = Simulation(dataclasses.replace(SMALL, settle_time=0.1), ORIGINAL)
    return sim


def test_settled_bed_is_a_random_3d_packing(settled_3d):
    report = settled_3d.settled_bed
    bed = bed_structure(settled_3d.snapshot())  # still the settled frame: nothing advanced yet
    assert bed.crossing_fraction > 0.7  # 0 for the old simple-cubic insertion
    assert 0.25 < bed.axial_fabric < 0.42  # isotropic: 1/3
    assert bed.coordination > 2  # particle contacts only: the walls hold many of these 200
    assert 0.35 < report["solid_fraction"] < 0.66  # random packings: 0.55-0.64 in the bulk, less near walls
    assert settled_3d.run_meta().provenance["settled_bed"] == report


def test_simulator_guard_measures_what_bed_structure_measures(settled_3d):
    """The simulator's settled-bed guard has its own copy of the rule (sim imports the core only)."""
    import sim.packing

    report, bed = settled_3d.settled_bed, bed_structure(settled_3d.snapshot())
    assert (report["n_touching"], report["n_particles"]) == (bed.n_touching, bed.n_particles)
    assert report["crossing_fraction"] == pytest.approx(bed.crossing_fraction, abs=1e-12)
    assert report["axial_fabric"] == pytest.approx(bed.axial_fabric, abs=1e-12)
    assert report["coordination"] == pytest.approx(bed.coordination, abs=1e-12)
    assert (sim.packing.PLANAR_FRACTION, sim.packing.AXIAL_NORMAL_MIN) == (ga.PLANAR_FRACTION,
                                                                           ga.analysis.bed.AXIAL_NORMAL_MIN)


def test_flowing_bed_moves_along_the_axis(settled_3d):
    sim = settled_3d  # the last test of this module to use it
    sim.advance(3000)
    bed = bed_structure(sim.snapshot())
    assert bed.axial_speed_ratio > 0.01 and bed.crossing_fraction > 0.5


def _cubic_lattice(params, radius, rng):
    """A planar insertion: a simple cubic lattice, axial spacing above every diameter, no offsets."""
    p = params
    spacing, margin = 2 * p.r_max * 1.02, p.r_max * 1.05
    axis = np.arange(-p.drum_radius + margin, p.drum_radius - margin + 1e-12, spacing)
    axis_z = np.arange(margin, p.drum_length - margin + 1e-12, spacing)
    g = np.stack(np.meshgrid(axis, axis, axis_z, indexing="ij"), -1).reshape(-1, 3)
    g = g[np.hypot(g[:, 0], g[:, 1]) < p.drum_radius * (1 - p.baffle_height) - margin]
    return g[np.lexsort((g[:, 0], g[:, 2], g[:, 1]))[: len(radius)]]


def test_simulator_refuses_to_start_the_drum_on_a_planar_bed(monkeypatch):
    import sim.run

    monkeypatch.setattr(sim.run, "insertion_positions", _cubic_lattice)
    with pytest.raises(ValueError, match=r"settled bed is planar: 0\.0 % of its \d+ touching contacts"):
        Simulation(dataclasses.replace(SMALL, settle_time=0.1), ORIGINAL)


def test_simulator_warns_on_a_bed_that_has_not_settled():
    with pytest.warns(UserWarning, match="has not settled after settle_time = 0.01 s"):
        Simulation(dataclasses.replace(SMALL, settle_time=0.01), ORIGINAL)


@pytest.mark.parametrize("maker, omega, warned", [(_planar_snapshot, 2.0, True), (_fcc_snapshot, 2.0, False),
                                                  (_planar_snapshot, 0.0, False)])
def test_info_reports_the_bed_and_warns_on_a_planar_drum_run(tmp_path, capsys, maker, omega, warned):
    path = tmp_path / "run.h5"
    snap = maker(None)
    meta = dataclasses.replace(synthetic_meta(snap.n_particles, drum_omega=omega), mean_radius=float(snap.radius.mean()))
    with RunWriter(path, meta) as writer:
        writer.append(dataclasses.replace(snap, meta=meta))
    assert cli_main(["info", str(path)]) == 0
    out, err = capsys.readouterr()
    assert "touching contacts cross axial layers" in out
    assert ("planar drum run" in err) == warned
    if warned:
        assert len(err.strip().splitlines()) == 1 and "0.0 % of" in err
    assert cli_main(["info", str(path), "--json"]) == 0
    import json

    report = json.loads(capsys.readouterr().out)["bed_last_frame"]
    assert report["planar"] == (maker is _planar_snapshot)
