"""Whole-run properties of the simulator: liquid conservation with spraying, the spray
schedule, confinement, determinism across thread counts, resume = uninterrupted, output."""

import dataclasses
import math

import numba
import numpy as np
import pytest

import granalytics as ga
from sim.params import _ORIGINALS, cg_scale
from sim.run import Simulation

ORIGINAL = dataclasses.replace(_ORIGINALS["lab"], n_particles=5400)
SMALL = dataclasses.replace(cg_scale(ORIGINAL, 3.0), settle_time=0.02, spray_interval=0.01, initial_film=0.004)


@pytest.fixture(scope="module")
def settled():
    return Simulation(SMALL, ORIGINAL)


def copy(sim):
    other = Simulation.__new__(Simulation)
    other.__dict__.update(sim.__dict__)
    other.state = dataclasses.replace(sim.state, **{
        f.name: getattr(sim.state, f.name).copy() for f in dataclasses.fields(sim.state)
        if isinstance(getattr(sim.state, f.name), np.ndarray)})
    return other


def test_liquid_is_conserved_and_sprayed_once_per_interval_inside_the_zone(settled):
    sim = copy(settled)
    p = sim.params
    assert sim.state.n_particles == 200
    total0 = sim.state.total_liquid()
    assert total0 == pytest.approx(sim.liquid_initial, rel=1e-15)
    frames = 12
    for k in range(frames):
        sim.advance(int(round(0.005 / p.dt)))
        s = sim.state
        expected = total0 + s.sprayed_total
        assert s.total_liquid() == pytest.approx(expected, rel=1e-12)
        assert (s.film >= 0).all() and (s.v_b >= 0).all()
    t = sim.time
    assert s.n_sprays == math.floor(t / p.spray_interval + 1e-9)
    assert s.sprayed_total > 0
    # bridges formed and carry liquid
    nw = s.n_particles * sim.n_walls
    assert (s.v_b[nw:][s.alive[nw:]] > 0).any()


def test_one_spray_doses_exactly_the_particles_inside_the_zone(settled):
    sim = copy(settled)
    p = sim.params
    steps_to_spray = math.ceil(p.spray_interval / p.dt)  # first step whose end reaches t = interval
    sim.advance(steps_to_spray - 1)
    before = sim.state.sprayed_total
    assert sim.state.n_sprays == 0
    sim.advance(1)
    s = sim.state
    assert s.n_sprays == 1
    inside = np.hypot(s.pos[:, 0], s.pos[:, 1]) < p.spray_radius
    dose = p.spray_dose * 4 / 3 * np.pi * s.radius**3
    assert s.sprayed_total - before == pytest.approx(dose[inside].sum(), rel=1e-12)
    assert 0 < inside.sum() < s.n_particles  # the zone covers part of the bed


def test_particles_stay_in_the_drum(settled):
    sim = copy(settled)
    sim.advance(int(round(0.05 / sim.params.dt)))
    s, p = sim.state, sim.params
    r = np.hypot(s.pos[:, 0], s.pos[:, 1])
    assert (r + s.radius <= p.drum_radius + 0.2 * s.radius).all()
    assert (s.pos[:, 2] > 0).all() and (s.pos[:, 2] < p.drum_length).all()


def test_bit_identical_for_one_and_two_threads(settled):
    results = []
    for threads in (1, 2):
        numba.set_num_threads(threads)
        sim = copy(settled)
        sim.advance(1500)
        results.append(sim.state)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    a, b = results
    for f in dataclasses.fields(a):
        assert np.array_equal(getattr(a, f.name), getattr(b, f.name)), f.name


def test_resumed_run_equals_uninterrupted_run(tmp_path):
    params = dataclasses.replace(SMALL, settle_time=0.01)
    frame_every = 400
    revs = 12 * frame_every * params.dt / params.revolution_period  # 12 frames after the first
    full = Simulation(params, ORIGINAL).run(tmp_path / "full.h5", revs, frame_every=frame_every, checkpoint_every=4, progress=False)
    part = tmp_path / "part.h5"
    # an interrupted run: it stopped after 7 frames (last checkpoint at frame 4)
    Simulation(params, ORIGINAL).run(part, revs * 6 / 12, frame_every=frame_every, checkpoint_every=4, progress=False)
    with ga.open_run(part) as run:
        assert len(run) == 7
    Simulation.resume(part).run(part, revs, frame_every=frame_every, checkpoint_every=4, progress=False, resume=True)
    with ga.open_run(full) as a, ga.open_run(part) as b:
        assert len(a) == len(b) == 13
        for fa, fb in zip(a, b):
            assert fa.time == fb.time
            for name in ("ids", "position", "velocity", "angular_velocity", "film_volume", "contact_i", "contact_j", "f_cap", "bridge_volume"):
                assert np.array_equal(getattr(fa, name), getattr(fb, name)), name
        meta = a.meta
    assert meta.alpha == 3.0 and meta.n_particles_original == 5400
    assert meta.sim_config["original"]["surface_tension"] == ORIGINAL.surface_tension
    assert meta.surface_tension == pytest.approx(3 * ORIGINAL.surface_tension)


def test_snapshot_is_a_valid_granalytics_frame_with_bridges(settled):
    sim = copy(settled)
    sim.advance(2000)
    snap = sim.snapshot()
    assert snap.n_particles == 200 and snap.n_contacts > 0
    assert (snap.contact_i < snap.contact_j).all()
    wet = snap.bridge_volume > 0
    assert wet.any() and (snap.f_cap[wet] > 0).all() and (snap.f_cap[~wet] == 0).all()
    result = ga.identify(snap)
    assert result.labels.shape == (200,)


def test_trajectory_does_not_depend_on_how_steps_are_split_into_calls(settled):
    a, b = copy(settled), copy(settled)
    a.advance(600)
    for _ in range(12):
        b.advance(50)
    for f in dataclasses.fields(a.state):
        assert np.array_equal(getattr(a.state, f.name), getattr(b.state, f.name)), f.name
