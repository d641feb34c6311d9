"""Whole-run properties of the simulator: liquid conservation with spraying, the spray
schedule, confinement, determinism across thread counts, resume = uninterrupted, output."""

import dataclasses
import os
import math
import re

import numba
import numpy as np
import pytest

import granalytics as ga
from sim.checkpoint import read_checkpoint, resume_run
from sim.params import cg_scale
from sim.run import Simulation
from sim.threads import ThreadGovernor, available_cores, thread_candidates

from conftest import former_lab_original  # noqa: E402

ORIGINAL = former_lab_original(5400)
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
    resume_run(part).run(part, revs, frame_every=frame_every, checkpoint_every=4, progress=False, resume=True)
    with ga.open_run(full) as a, ga.open_run(part) as b:
        assert len(a) == len(b) == 13
        assert a.meta.provenance["planned_frames"] == b.meta.provenance["planned_frames"] == 13
        # the CPU time of all sittings, no less than the uninterrupted run's frames took
        for meta in (a.meta, b.meta):
            cpu = meta.provenance["cpu_time_s"]
            assert cpu > 0 and meta.provenance["cpu_time_per_simulated_s"] == pytest.approx(
                cpu / meta.provenance["simulated_time_s"])
        assert resume_run(part).resume_point.cpu_s > 0
        for meta in (a.meta, b.meta):  # the settling's cost, apart from the run's
            assert meta.provenance["settle_wall_time_s"] > 0 and meta.provenance["settle_cpu_time_s"] > 0
        assert a.unfinished is None and b.unfinished is None
        for fa, fb in zip(a, b):
            assert fa.time == fb.time
            for name in ("ids", "position", "velocity", "angular_velocity", "film_volume", "contact_i", "contact_j", "f_cap", "bridge_volume"):
                assert np.array_equal(getattr(fa, name), getattr(fb, name)), name
        meta = a.meta
    assert meta.alpha == 3.0 and meta.n_particles_original == 5400
    assert meta.sim_config["original"]["surface_tension"] == ORIGINAL.surface_tension
    assert meta.surface_tension == pytest.approx(3 * ORIGINAL.surface_tension)


def test_a_run_checkpointed_between_frames_resumes_to_the_uninterrupted_run(tmp_path, monkeypatch):
    """checkpoint_minutes: checkpoints between frames (here after every piece of a frame); a run
    stopped right after one resumes from that step and writes the uninterrupted run's frames."""
    import sim.run as sim_run

    params = dataclasses.replace(SMALL, settle_time=0.01)
    frame_every = 400
    revs = 6 * frame_every * params.dt / params.revolution_period  # 6 frames after the first
    full = Simulation(params, ORIGINAL).run(tmp_path / "full.h5", revs, frame_every=frame_every, checkpoint_every=None,
                                            progress=False)
    written = []
    real_write = sim_run.write_checkpoint

    class Stop(Exception):
        pass

    def write_then_stop(sim, path, extra):
        real_write(sim, path, extra)
        written.append((sim.state.step, extra["frames"]))
        if sim.state.step == 3 * frame_every + 5 * (frame_every // 20):  # inside frame 4, after frame 3
            raise Stop

    monkeypatch.setattr(sim_run, "write_checkpoint", write_then_stop)
    part = tmp_path / "part.h5"
    with pytest.raises(Stop):
        Simulation(params, ORIGINAL).run(part, revs, frame_every=frame_every, checkpoint_every=None, progress=False,
                                         checkpoint_minutes=1e-9)
    monkeypatch.setattr(sim_run, "write_checkpoint", real_write)
    assert written[0] == (0, 1)  # the settled bed
    assert all((frames - 1) * frame_every <= step < frames * frame_every for step, frames in written)
    point = resume_run(part).resume_point
    assert point.frames == 4 and resume_run(part).state.step == 3 * frame_every + 100
    # resumed for fewer revolutions, the checkpoint's state would lie past the requested last frame
    with pytest.raises(ValueError, match="lies past the last frame of the requested run \\(frame 3"):
        resume_run(part).run(part, revs / 2, frame_every=frame_every, checkpoint_every=None, progress=False,
                             resume=True)
    resume_run(part).run(part, revs, frame_every=frame_every, checkpoint_every=None, progress=False, resume=True,
                         checkpoint_minutes=1e-9)
    assert_same_run(full, part, n_frames=7)
    with pytest.raises(ValueError, match="checkpoint_minutes must be a finite number > 0"):
        Simulation(params, ORIGINAL).run(tmp_path / "x.h5", revs, frame_every=frame_every, checkpoint_minutes=0)


def test_a_resumed_runs_progress_bar_starts_part_way_into_its_frame(tmp_path, capsys):
    """The bar counts frames in fractions of the steps simulated, so a run resumed part-way into a
    frame starts there: its rate, and the time left, are of the new sitting's work only (a bar
    counting whole frames took the first, part-done frame as a whole one and showed hours too few
    at 120 000 particles)."""
    params = dataclasses.replace(SMALL, settle_time=0.01)
    frame_every = 400
    revs = 4 * frame_every * params.dt / params.revolution_period  # frames 0-4
    out = tmp_path / "run.h5"
    sim = Simulation(params, ORIGINAL)
    advance, calls = sim.advance, []

    def stopped_in_the_third_frame(n_steps):
        advance(n_steps)
        calls.append(n_steps)
        if len(calls) == 2 * 20 + 7:  # pieces of 1/20 of a frame with checkpoint_minutes
            raise KeyboardInterrupt

    sim.advance = stopped_in_the_third_frame
    capsys.readouterr()
    with pytest.raises(KeyboardInterrupt):
        sim.run(out, revs, frame_every=frame_every, checkpoint_minutes=1e-9, progress=True)
    assert re.search(r"\| 1\.00/5 \[", capsys.readouterr().err)  # a new run: the settled bed's frame made
    resumed = resume_run(out)
    step = resumed.state.step
    assert step % frame_every and step // frame_every == 2  # checkpointed part-way into frame 3
    capsys.readouterr()
    resumed.run(out, revs, frame_every=frame_every, checkpoint_minutes=1e-9, progress=True, resume=True)
    shown = [float(n) for n in re.findall(r"\| (\d+\.\d\d)/5 \[", capsys.readouterr().err)]
    assert shown[0] == pytest.approx(step / frame_every + 1, abs=0.006) and shown[-1] == 5.0


def test_a_run_goes_on_in_a_new_part_from_a_kept_checkpoint_as_if_uninterrupted(tmp_path):
    """A run whose files are lost but whose checkpoint was kept (a compacted copy elsewhere) goes on
    in a new file, a part holding the frames from the checkpoint's next one: they are the
    uninterrupted run's frames, and the part resumes from its own checkpoint like any run."""
    from sim.checkpoint import checkpoint_path, compact_checkpoint
    from sim.state import SLOT_OUTPUT_FIELDS

    params = dataclasses.replace(SMALL, settle_time=0.01)
    frame_every = 400
    revs = 12 * frame_every * params.dt / params.revolution_period  # 12 frames after the first
    full = Simulation(params, ORIGINAL).run(tmp_path / "full.h5", revs, frame_every=frame_every, checkpoint_every=None,
                                            progress=False)
    lost = tmp_path / "lost.h5"  # stopped after 6 frames, its last checkpoint at frame 4
    Simulation(params, ORIGINAL).run(lost, revs * 5 / 12, frame_every=frame_every, checkpoint_every=4, progress=False)
    kept = tmp_path / "kept.ckpt.npz"
    assert compact_checkpoint(checkpoint_path(lost), kept) < os.path.getsize(checkpoint_path(lost)) / 2
    with np.load(kept) as copy, np.load(checkpoint_path(lost)) as original:
        assert set(copy.files) == set(original.files)
        assert any(original[name].any() for name in SLOT_OUTPUT_FIELDS)  # the outputs it drops were there
        for name in copy.files:
            assert np.array_equal(copy[name], 0 * original[name] if name in SLOT_OUTPUT_FIELDS else original[name])
    (tmp_path / "bad.npz").write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match="bad.npz: damaged checkpoint"):
        compact_checkpoint(tmp_path / "bad.npz", tmp_path / "bad-copy.npz")
    assert not os.path.exists(tmp_path / "bad-copy.npz")
    os.unlink(lost)
    os.unlink(checkpoint_path(lost))
    part = tmp_path / "part.h5"
    # the part is made in two sittings: the first stops after frame 9 of the run, the second resumes it
    resume_run(part, from_checkpoint=kept).run(part, revs * 9 / 12, frame_every=frame_every, checkpoint_every=4,
                                               progress=False, new_part=True)
    assert resume_run(part).resume_point.frames == 8  # the part's own checkpoint counts the run's frames
    resume_run(part).run(part, revs, frame_every=frame_every, checkpoint_every=4, progress=False, resume=True)
    with ga.open_run(full) as a, ga.open_run(part) as b:
        assert b.meta.provenance["first_frame"] == 4 and b.meta.provenance["planned_frames"] == 9
        assert b.unfinished is None
        # the cost counts every sitting, those of the lost file included
        assert b.meta.provenance["cpu_time_s"] > resume_run(kept, from_checkpoint=kept).resume_point.cpu_s > 0
        assert len(b) == 9
        for fa, fb in zip(a[4:], b):
            assert fa.time == fb.time and fa.step == fb.step
            for name in ("ids", "position", "velocity", "angular_velocity", "film_volume", "contact_i", "contact_j",
                         "f_cap", "f_normal", "gap", "bridge_volume"):
                assert np.array_equal(getattr(fa, name), getattr(fb, name)), name
    # a part of a run that ends at the checkpoint's frames is refused: nothing is left to make
    with pytest.raises(ValueError, match="after 4 frames, the requested run has 4: no frame is left"):
        resume_run(tmp_path / "p2.h5", from_checkpoint=kept).run(
            tmp_path / "p2.h5", revs * 3 / 12, frame_every=frame_every, checkpoint_every=4, progress=False,
            new_part=True)
    with pytest.raises(ValueError, match="frame every 400 steps, the resumed run asks for 200"):
        resume_run(tmp_path / "p3.h5", from_checkpoint=kept).run(
            tmp_path / "p3.h5", revs, frame_every=200, checkpoint_every=4, progress=False, new_part=True)
    with pytest.raises(ValueError, match="give one of them"):
        resume_run(part).run(part, revs, frame_every=frame_every, progress=False, resume=True, new_part=True)
    assert not os.path.exists(tmp_path / "p2.h5") and not os.path.exists(tmp_path / "p3.h5")


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
    # particles by id and contacts by pair, whatever order the simulator keeps its rows in
    s = sim.state
    by_id = np.argsort(s.ids)
    assert np.array_equal(snap.ids, np.arange(200)) and not np.array_equal(s.ids, snap.ids)
    assert np.array_equal(snap.position, s.pos[by_id]) and np.array_equal(snap.film_volume, s.film[:200][by_id])
    assert (np.diff(snap.contact_i * 200 + snap.contact_j) > 0).all()


def test_trajectory_does_not_depend_on_how_steps_are_split_into_calls(settled):
    a, b = copy(settled), copy(settled)
    a.advance(600)
    for _ in range(12):
        b.advance(50)
    for f in dataclasses.fields(a.state):
        assert np.array_equal(getattr(a.state, f.name), getattr(b.state, f.name)), f.name


@pytest.mark.filterwarnings("ignore:the simulator slowed")  # millisecond windows: rates scatter
def test_the_thread_governor_leaves_the_trajectory_bit_identical(settled):
    a, b = copy(settled), copy(settled)
    numba.set_num_threads(1)
    a.advance(600)
    b.threads = "auto"
    # windows of a millisecond and calls capped at a fraction of one: the count changes every few
    # calls, and calls end at their cap rather than at a rebuild
    b._governor = ThreadGovernor(probe_s=1e-3, window_s=1e-3, first_recheck_s=0.0, recheck_s=0.0, call_s=1e-4)
    b.advance(600)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    used = {threads for threads, _ in b._governor.history}
    switches = sum(t0 != t1 for (t0, _), (t1, _) in zip(b._governor.history, b._governor.history[1:]))
    assert len(used) == len(b._governor.candidates) and b._governor._calls > 12
    assert switches > 2 or len(used) == 1
    for f in dataclasses.fields(a.state):
        assert np.array_equal(getattr(a.state, f.name), getattr(b.state, f.name)), f.name


def test_thread_candidates_are_powers_of_two_and_the_maximum():
    assert thread_candidates(1) == [1] and thread_candidates(2) == [1, 2]
    assert thread_candidates(6) == [1, 2, 4, 6] and thread_candidates(8) == [1, 2, 4, 8]


@pytest.mark.skipif(min(available_cores(), numba.config.NUMBA_NUM_THREADS) < 2, reason="needs two cores")
def test_the_thread_governor_runs_on_the_faster_count_and_probes_again_when_the_rate_falls():
    now = [0.0]
    gov = ThreadGovernor(max_threads=2, probe_s=1.0, probe_slices=1, window_s=1.0, first_recheck_s=10.0,
                         recheck_s=40.0, clock=lambda: now[0])
    speed = {1: 2e6, 2: 3e6}  # particle-steps/s at each count

    def calls(k):
        for _ in range(k):
            gov.begin(1000, 10**9)
            now[0] += 0.5
            gov.end(int(speed[gov.threads] * 0.5 / 1000), 1000, 0.5)

    calls(5)  # the first call is not measured; then 1 s on one thread, 1 s on two
    assert gov.rates == pytest.approx({1: 2e6, 2: 3e6}) and gov.threads == 2 and not gov.probing
    calls(8)
    assert gov.threads == 2 and not gov.probing  # no new probe before first_recheck_s
    speed[2] = 0.1e6  # another program takes a core: the second thread stalls the first at every barrier
    with pytest.warns(RuntimeWarning, match=r"slowed to 0.10M particle-steps/s from 3.00M .* busy"):
        calls(2)
    calls(4)  # a probe at once, not after recheck_s
    assert gov.threads == 1 and not gov.probing and gov.rates[2] == pytest.approx(0.1e6)
    speed[2] = 3e6  # the other program ended: the next recheck finds two threads faster again
    t_chosen = now[0]
    calls(30)
    assert gov.threads == 2 and now[0] - t_chosen > 10.0
    assert numba.get_num_threads() == 2
    # a probe that keeps the count doubles the time to the next one, up to recheck_s
    calls(200)
    assert gov.threads == 2 and gov._interval == 40.0
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)


@pytest.mark.skipif(min(available_cores(), numba.config.NUMBA_NUM_THREADS) < 2, reason="needs two cores")
def test_the_governors_probe_interleaves_the_counts_and_a_fall_on_one_thread_starts_no_probe():
    """A probe alternates the counts (1, 2, 1, 2), so that load which comes and goes is seen by
    both; its rate per count is over all its slices. Once on one thread, a falling rate (the
    machine got busier) starts no probe of more threads before the recheck is due."""
    now = [0.0]
    gov = ThreadGovernor(max_threads=2, probe_s=1.0, probe_slices=2, window_s=1.0, first_recheck_s=10.0,
                         recheck_s=40.0, clock=lambda: now[0])
    # two threads are fast only in their first slice (another program starts at t = 1.5 s)
    speed = lambda threads: {1: 2e6, 2: 3e6 if now[0] < 1.5 else 0.5e6}[threads]

    def calls(k):
        for _ in range(k):
            gov.begin(1000, 10**9)
            rate = speed(gov.threads)
            now[0] += 0.5
            gov.end(int(rate * 0.5 / 1000), 1000, 0.5)

    calls(5)  # the first call is not measured; then four slices of 0.5 s
    assert [t for t, _ in gov.history] == [1, 2, 1, 2] and not gov.probing
    assert gov.rates[2] == pytest.approx((3e6 + 0.5e6) / 2) and gov.threads == 1  # not 3e6 from one lucky slice
    speed = lambda threads: {1: 0.9e6, 2: 0.3e6}[threads]  # busier still: one thread at 0.45 of its chosen rate
    with pytest.warns(RuntimeWarning, match="slowed to 0.90M"):
        calls(12)  # six 1-s windows, all on one thread, none a probe
    assert gov.threads == 1 and not gov.probing and [t for t, _ in gov.history[4:]] == [1] * 6
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)


def test_threads_refuses_counts_outside_numbas_pool(settled):
    sim = copy(settled)
    for bad in (0, numba.config.NUMBA_NUM_THREADS + 1, "all", 1.5, True):
        with pytest.raises(ValueError, match="threads must be 'auto' or a whole number"):
            sim.threads = bad


# --- kernel seams: parameters by name, trajectory unchanged --------------------------------------

def test_the_force_passes_count_every_blocks_events_and_reset_only_the_last_steps_flags(settled):
    # liquid migration visits only the blocks in which the force passes counted a creation or a
    # rupture, so a count that misses one would lose liquid silently
    import copy

    from sim import _kernels
    from sim.drum import baffle_directions
    from sim.liquid import migrate_events

    s, p = copy.deepcopy(settled.state), settled.params
    n, n_walls, n_slots = s.n_particles, settled.n_walls, s.pair_i.shape[0]
    kernel_params = _kernels.kernel_params(p, n_walls)
    body_key = np.concatenate([s.ids, s.ids.max() + 1 + np.arange(n_walls)])
    arrays = _kernels.kernel_arrays(s, body_key)
    n_wb, n_pb = _kernels.event_blocks(n, n_walls, n_slots)
    bounds = [min(b * _kernels.WALL_BLOCK, n) * n_walls for b in range(n_wb + 1)]
    bounds += [n * n_walls + b * _kernels.PAIR_BLOCK for b in range(1, n_pb)] + [n_slots]
    blocks = np.zeros(n_wb + n_pb, dtype=np.int64)
    _kernels.count_block_events(s.created, s.ruptured, n, n_walls, blocks)
    baffle_dir = np.empty((p.n_baffles + 1, 2))
    events_seen = 0
    for step in range(300):
        # drive the system hard (a fast drum) so that contacts form and bridges break every step
        baffle_directions(p.n_baffles, 0.01 * step, baffle_dir)
        was_alive = s.alive.copy()
        _kernels._slot_forces(0, n_wb, baffle_dir, 20.0, blocks, kernel_params, arrays)
        _kernels._slot_forces(n_wb, n_wb + n_pb, baffle_dir, 20.0, blocks, kernel_params, arrays)
        flagged = s.created | (s.ruptured != 0.0)
        # the flags left are exactly this step's events (the previous step's were reset) ...
        assert np.array_equal(s.created, s.alive & ~was_alive)
        assert np.array_equal(s.ruptured != 0.0, (was_alive & ~s.alive) & (s.ruptured != 0.0))
        assert not (s.ruptured != 0.0)[s.alive | ~was_alive].any()
        # ... and each block's count is the number of flagged slots in it
        expected = np.add.reduceat(flagged.astype(np.int64), bounds[:-1])
        assert np.array_equal(blocks, expected)
        events_seen += int(blocks.sum())
        lo = np.empty(blocks.size, dtype=np.int64)
        hi = np.empty(blocks.size, dtype=np.int64)
        m = _kernels.event_ranges(blocks, n, n_walls, n_slots, lo, hi)
        assert sum(flagged[a:b].sum() for a, b in zip(lo[:m], hi[:m])) == flagged.sum()
        migrate_events(s.film, s.pair_i, s.pair_j, s.v_b, s.v_max, s.alive, s.created, s.ruptured, s.body_start,
                       s.body_slots, p.v_min, body_key, lo[:m], hi[:m])
        _kernels._gather_integrate(kernel_params, arrays)
    assert events_seen > 100


def test_kernel_parameters_are_passed_by_name_from_simparams():
    import inspect

    from sim import _kernels
    from sim.capillary import CAPILLARY_MODELS
    from sim.contact import LAW_CONSTANTS
    from sim.laws import CONTACT_LAWS

    # every float parameter distinct, so that a swapped pair cannot go unnoticed
    p = dataclasses.replace(SMALL, k_n=101.0, k_t=102.0, c_n=0.0103, c_t=0.0104, friction=0.45,
                            surface_tension=0.31, viscosity=0.0027, contact_angle=0.21, v_min=1e-15,
                            spray_interval=0.011, spray_dose=0.012, spray_radius=0.013, skin=0.9e-3,
                            baffle_height=0.14, cylinder_facets=5, drum_omega=2.5, gravity=(0.1, -9.7, 0.2),
                            capillary_model="lambert", viscous=False, capillary_in_contact=True)
    kernel_params = _kernels.kernel_params(p, 7)
    by_name = {"dt": p.dt, "n_walls": 7, "drum_radius": p.drum_radius, "drum_length": p.drum_length,
               "n_baffles": p.n_baffles, "baffle_height": 0.14, "cylinder_facets": 5, "drum_omega": 2.5, "gx": 0.1, "gy": -9.7, "gz": 0.2,
               "law": 0, "law_constants": (101.0, 102.0, 0.0103, 0.0104, 0.45) + (0.0,) * (LAW_CONSTANTS - 5),
               "registered_laws": tuple(range(len(CONTACT_LAWS))), "gamma": 0.31,
               "eta": 0.0027, "theta": 0.21, "model": CAPILLARY_MODELS["lambert"], "viscous": False,
               "capillary_in_contact": True, "v_min": 1e-15, "bridge_volume": 0.0, "wall_bridges": True, "spray_interval": 0.011, "spray_dose": 0.012,
               "spray_radius": 0.013, "half_skin": 0.45e-3}
    assert kernel_params._asdict() == by_name
    assert [type(v) for v in kernel_params] == [type(by_name[k]) for k in kernel_params._fields]
    assert all(type(v) is float for v in kernel_params.law_constants)
    # the time-step kernels take the parameters and the arrays as two named structures
    for kernel in (_kernels.advance, _kernels._slot_forces):
        params = list(inspect.signature(kernel.py_func).parameters)
        assert len(params) <= 7 and params[-2:] == ["kernel_params", "arrays"], params
    state = Simulation.from_particles(p, [[0.0, -0.02, 0.01], [0.005, -0.02, 0.01]], [0.002, 0.002]).state
    arrays = _kernels.kernel_arrays(state, np.arange(2 + 7))
    assert arrays.pos is state.pos and arrays.f_cap is state.f_cap and arrays.omega is state.omega


# The state after filling, settling and 2 500 steps of two configurations, stored in
# tests/data/reference_trajectory.npz by ``python tests/test_sim_run.py`` (physics version 4, on the
# machine that made it). Regenerate it only for an intentional change of the physics, and say so in
# the commit. The same code gives different last bits on different CPUs (glibc's libm variant and
# numpy's vectorised functions are chosen by CPU features), and the granular dynamics amplify them:
# measured here by moving every position by one ulp after the settling, the two trajectories differ
# after 2 500 steps by 2.5e-12 d in position and 9e-12 m/s in velocity (default configuration;
# 4.4e-13 d and 1.7e-12 m/s for the variant), with identical films, sprays and bridge counts. The
# tolerances below are 4 000 times that: any change of the physics or of the integration moves
# the state by far more, and any x86-64 CPU passes.
REFERENCE_TRAJECTORY = os.path.join(os.path.dirname(__file__), "data", "reference_trajectory.npz")
TRAJECTORY_CONFIGS = {
    "default": SMALL,
    "variant": dataclasses.replace(SMALL, capillary_model="rabinovich", capillary_in_contact=True, viscous=False,
                                   v_min=1e-13, contact_angle=0.2, friction=0.4, spray_dose=0.02, seed=3),
}


def _trajectory_end(config) -> dict:
    """The state of ``config`` after the filling, the settling and 2 500 steps, by particle id."""
    sim = Simulation(TRAJECTORY_CONFIGS[config], ORIGINAL)
    sim.advance(2500)
    s = sim.state
    order = np.argsort(s.ids)
    return {"pos": s.pos[order], "vel": s.vel[order], "omega": s.omega[order], "film": s.film[:len(order)][order],
            "n_sprays": s.n_sprays, "bridges": int(s.alive.sum()), "liquid": s.total_liquid()}


@pytest.mark.parametrize("config", list(TRAJECTORY_CONFIGS))
def test_trajectory_matches_the_stored_reference_within_cpu_to_cpu_differences(config):
    end = _trajectory_end(config)
    with np.load(REFERENCE_TRAJECTORY) as stored:
        reference = {name: stored[f"{config}_{name}"] for name in end}
    d = TRAJECTORY_CONFIGS[config].d_mean
    assert end["n_sprays"] == reference["n_sprays"] == 2 and end["bridges"] == reference["bridges"]
    np.testing.assert_allclose(end["pos"], reference["pos"], rtol=0, atol=1e-8 * d)
    np.testing.assert_allclose(end["vel"], reference["vel"], rtol=0, atol=4e-8)
    np.testing.assert_allclose(end["omega"], reference["omega"], rtol=0, atol=4e-8 / d)
    np.testing.assert_allclose(end["film"], reference["film"], rtol=1e-9, atol=1e-9 * d**3)
    assert end["liquid"] == pytest.approx(float(reference["liquid"]), rel=1e-12)


def test_the_same_seed_and_thread_count_give_bit_identical_trajectories():
    first, second = _trajectory_end("default"), _trajectory_end("default")
    for name in ("pos", "vel", "omega", "film"):
        assert np.array_equal(first[name], second[name]), name


# --- global state ---------------------------------------------------------------------------------

def _python(code, **env_extra):
    """Run ``code`` in a fresh interpreter without GOMP_SPINCOUNT in its environment (plus
    ``env_extra``); its stdout."""
    import subprocess
    import sys

    env = {**{k: v for k, v in os.environ.items() if k != "GOMP_SPINCOUNT"}, **env_extra}
    return subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True).stdout


def test_importing_granalytics_and_sim_and_their_force_laws_changes_no_global_state():
    out = _python(
        "import os, numba\n"
        "os.environ.pop('GOMP_SPINCOUNT', None)\n"
        "numba.config.THREADING_LAYER_PRIORITY = default = ['tbb', 'omp', 'workqueue']\n"
        "import granalytics, granalytics.identification.kernels, granalytics.report.figures, granalytics.cli\n"
        "import sim, sim.run, sim.cli, sim._kernels, sim.neighbours\n"
        "sim.capillary_force(1e-5, 1e-3, 1e-3, 1e-12, 0.1)\n"
        "print(os.environ.get('GOMP_SPINCOUNT'), numba.config.THREADING_LAYER_PRIORITY == default)\n")
    assert out.split() == ["None", "True"]


def test_creating_and_running_a_simulation_changes_no_process_state():
    # the library leaves the process as it finds it: numba's layer priority, GOMP_SPINCOUNT and
    # glibc's allocator (a 64 MB array still comes from mmap-backed blocks after the run)
    out = _python(
        "import ctypes, os, numba, numpy as np\n"
        "from sim.params import SimParams\n"
        "from sim.run import Simulation\n"
        "default = list(numba.config.THREADING_LAYER_PRIORITY)\n"
        "p = SimParams(n_particles=2, n_baffles=0, drum_omega=0.0, drum_radius=0.05, drum_length=0.05)\n"
        "Simulation.from_particles(p, [[0, -0.02, 0.02], [0.0016, -0.02, 0.02]], [7.5e-4, 7.5e-4]).advance(2)\n"
        "mmapped = -1\n"
        "try:\n"
        "    libc = ctypes.CDLL('libc.so.6')\n"
        "    class Info(ctypes.Structure):\n"
        "        _fields_ = [(f, ctypes.c_size_t) for f in ('arena ordblks smblks hblks hblkhd usmblks fsmblks '\n"
        "                                                     'uordblks fordblks keepcost').split()]\n"
        "    libc.mallinfo2.restype = Info\n"
        "    h0 = libc.mallinfo2().hblkhd\n"
        "    a = np.ones(8_000_000)\n"
        "    mmapped = libc.mallinfo2().hblkhd - h0\n"
        "except (OSError, AttributeError):\n"
        "    pass\n"
        "print(os.environ.get('GOMP_SPINCOUNT'), numba.config.THREADING_LAYER_PRIORITY == default, mmapped)\n")
    gomp, same_priority, mmapped = out.split()
    assert (gomp, same_priority) == ("None", "True")
    if _has_mallinfo2():
        assert int(mmapped) >= 64_000_000


def test_the_command_line_sets_up_openmp_for_its_run():
    # python -m sim run tunes its own process first thing (here before it refuses --revolutions 0)
    out = _python(
        "import os, numba, sys\n"
        "from sim.cli import main\n"
        "rc = main(['run', '--preset', 'lab-cg3', '--revolutions', '0', '--out', 'never.h5', '--quiet'])\n"
        "print(rc, os.environ.get('GOMP_SPINCOUNT'), numba.config.THREADING_LAYER_PRIORITY[0])\n")
    assert out.split()[-3:] == ["2", "3000", "omp"]


def test_threads_started_before_the_set_up_give_a_warning_naming_the_layer():
    out = _python("import warnings, numba\n"
                  "numba.set_num_threads(1)\n"  # launches numba's threads with its own layer choice
                  "from sim.threads import configure_threading\n"
                  "with warnings.catch_warnings(record=True) as caught:\n"
                  "    warnings.simplefilter('always')\n"
                  "    configure_threading(); configure_threading()\n"
                  "print(len(caught), caught[0].message if caught else '')\n", NUMBA_THREADING_LAYER="workqueue")
    assert out.startswith("1 ") and "'workqueue'" in out and "configure_threading() before" in out


def _has_mallinfo2():
    """glibc 2.33 or later (the allocator set-up and ``mallinfo2`` are glibc's)."""
    import ctypes

    try:
        return os.confstr("CS_GNU_LIBC_VERSION").startswith("glibc") and hasattr(ctypes.CDLL("libc.so.6"), "mallinfo2")
    except (AttributeError, ValueError, OSError):
        return False


@pytest.mark.skipif(not _has_mallinfo2(), reason="needs glibc >= 2.33 (mallinfo2)")
def test_the_set_up_serves_large_arrays_from_the_reusable_heap():
    # glibc's mallinfo2().hblkhd: bytes held in mmap-backed blocks, which are unmapped on free
    # and come back as fresh pages; after the set-up a 64 MB array is not one of them
    out = _python(
        "import ctypes, numpy as np\n"
        "from sim.threads import configure_threading\n"
        "class Info(ctypes.Structure):\n"
        "    _fields_ = [(f, ctypes.c_size_t) for f in ('arena ordblks smblks hblks hblkhd usmblks fsmblks '\n"
        "                                                 'uordblks fordblks keepcost').split()]\n"
        "libc = ctypes.CDLL('libc.so.6')\n"
        "libc.mallinfo2.restype = Info\n"
        "def mmapped_bytes_of_64_mb_array():\n"
        "    h0 = libc.mallinfo2().hblkhd\n"
        "    a = np.ones(8_000_000)\n"
        "    return libc.mallinfo2().hblkhd - h0\n"
        "before = mmapped_bytes_of_64_mb_array()\n"
        "configure_threading()\n"
        "print(before, mmapped_bytes_of_64_mb_array())\n")
    before, after = map(int, out.split())
    assert before >= 64_000_000 and after == 0


# --- checkpoints: one atomic file, kills at any point ---------------------------------------------

RESUME_PARAMS = dataclasses.replace(SMALL, settle_time=0.01)
FRAME_EVERY = 400
REVS = 12 * FRAME_EVERY * RESUME_PARAMS.dt / RESUME_PARAMS.revolution_period  # 12 frames after the first


class Killed(BaseException):
    """Stands for SIGKILL: no ``except Exception`` clean-up runs."""


@pytest.fixture(scope="module")
def full_run(tmp_path_factory):
    path = tmp_path_factory.mktemp("full") / "full.h5"
    Simulation(RESUME_PARAMS, ORIGINAL).run(path, REVS, frame_every=FRAME_EVERY, checkpoint_every=4, progress=False)
    return path


def assert_same_run(a_path, b_path, n_frames=13):
    with ga.open_run(a_path) as a, ga.open_run(b_path) as b:
        assert len(a) == len(b) == n_frames
        for fa, fb in zip(a, b):
            assert fa.time == fb.time and fa.step == fb.step
            for name in ("ids", "position", "velocity", "angular_velocity", "film_volume", "contact_i", "contact_j",
                         "f_cap", "f_normal", "gap", "bridge_volume"):
                assert np.array_equal(getattr(fa, name), getattr(fb, name)), name


@pytest.mark.parametrize("point, resumed_from", [
    ("write", 4),          # killed while writing the temporary file
    ("fsync", 4),          # written, killed before it reached the disk
    ("replace", 4),        # killed just before the rename
    ("after replace", 8),  # renamed, killed before anything else happened
])
def test_a_kill_at_any_point_of_a_checkpoint_leaves_a_complete_one(tmp_path, monkeypatch, full_run, point, resumed_from):
    import os

    from sim import run as sim_run

    part = tmp_path / "part.h5"
    ckpt = f"{part}.ckpt.npz"
    real_savez, real_fsync, real_replace = np.savez, os.fsync, os.replace
    armed = {"on": False}  # the second checkpoint (frame 8) is killed; the first completes
    save = sim_run.write_checkpoint

    def saving(sim, path, extra=None):
        armed["on"] = extra["frames"] == 8
        save(sim, path, extra)

    def savez(file, *args, **kwds):
        if armed["on"] and point == "write":
            if isinstance(file, (str, os.PathLike)):
                file = open(file, "wb")
            file.write(b"PK\x03\x04 half a checkpoint")
            file.flush()
            raise Killed
        return real_savez(file, *args, **kwds)

    def fsync(fd):
        if armed["on"] and point == "fsync":
            raise Killed
        return real_fsync(fd)

    def replace(src, dst):
        if armed["on"] and os.fspath(dst).startswith(ckpt):
            if point == "replace":
                raise Killed
            real_replace(src, dst)
            if point == "after replace":
                raise Killed
            return None
        return real_replace(src, dst)

    monkeypatch.setattr(sim_run, "write_checkpoint", saving)
    monkeypatch.setattr(np, "savez", savez)
    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(Killed):
        Simulation(RESUME_PARAMS, ORIGINAL).run(part, REVS, frame_every=FRAME_EVERY, checkpoint_every=4, progress=False)
    monkeypatch.undo()
    # one complete checkpoint, consistent in itself: the previous one or the new one
    sim, info = read_checkpoint(ckpt)
    assert info["frames"] == resumed_from and info["frame_every"] == FRAME_EVERY
    assert sim.state.step == (resumed_from - 1) * FRAME_EVERY
    resume_run(part).run(part, REVS, frame_every=FRAME_EVERY, checkpoint_every=4, progress=False, resume=True)
    assert_same_run(full_run, part)


#: a run file of 3 frames and its checkpoint after frame 1, written by the simulator before its
#: checkpoints moved into sim/checkpoint.py (format 2, physics version 4; tests/data/README.md):
#: the files that the long runs going on resume from
FORMAT_2_RUN = os.path.join(os.path.dirname(__file__), "data", "checkpoint_format_2", "run.h5")
SNAPSHOT_FIELDS = ("ids", "radius", "position", "velocity", "angular_velocity", "film_volume", "contact_i", "contact_j",
                   "f_normal", "gap", "bridge_volume")


def test_a_stored_checkpoint_of_format_2_is_read_written_again_unchanged_and_resumed(tmp_path):
    import json
    import shutil

    from sim.checkpoint import write_checkpoint

    stored = f"{FORMAT_2_RUN}.ckpt.npz"
    sim, info = read_checkpoint(stored)
    assert info["frames"] == 2 and info["frame_every"] == 700 and info["physics_version"] == 4
    # written again: the same names in the same order, the same dtypes, shapes and values, the same JSON
    write_checkpoint(sim, tmp_path / "again.ckpt.npz", info)
    with np.load(stored) as old, np.load(tmp_path / "again.ckpt.npz") as new:
        assert new.files == old.files
        for name in old.files:
            assert new[name].dtype == old[name].dtype and np.array_equal(new[name], old[name]), name
        assert json.loads(str(old["checkpoint_info"]))["format"] == 2
    # the restored state is the uninterrupted run's at the checkpoint: its frame 1, bit for bit
    with ga.open_run(FORMAT_2_RUN) as run:
        frames = list(run)
    restored = sim.snapshot()
    assert restored.step == frames[1].step == 700 and restored.time == frames[1].time
    for name in SNAPSHOT_FIELDS:
        assert np.array_equal(getattr(restored, name), getattr(frames[1], name)), name
    np.testing.assert_allclose(restored.f_cap, frames[1].f_cap, rtol=1e-12, atol=0)
    # resumed: straight to frame 6, and with a stop at the checkpoint of frame 4 written by this simulator
    rev = 700 * sim.params.dt / sim.params.revolution_period
    for name in ("straight", "stopped"):
        os.mkdir(tmp_path / name)
        shutil.copyfile(FORMAT_2_RUN, tmp_path / name / "run.h5")
        shutil.copyfile(stored, tmp_path / name / "run.h5.ckpt.npz")
    straight, stopped = tmp_path / "straight" / "run.h5", tmp_path / "stopped" / "run.h5"
    resume_run(straight).run(straight, 6 * rev, frame_every=700, checkpoint_every=None, progress=False, resume=True)
    resume_run(stopped).run(stopped, 4 * rev, frame_every=700, checkpoint_every=2, progress=False, resume=True)
    assert resume_run(stopped).resume_point.frames == 4
    resume_run(stopped).run(stopped, 6 * rev, frame_every=700, checkpoint_every=2, progress=False, resume=True)
    assert_same_run(straight, stopped, n_frames=7)
    # a format-2 checkpoint written before CPU time was recorded: the run's CPU time is unknown, not partial
    assert resume_run(stopped).resume_point.cpu_s is None
    with ga.open_run(straight) as run:
        assert run.meta.provenance["cpu_time_s"] is None and run.meta.provenance["wall_time_s"] > 0
    with ga.open_run(straight) as run:
        resumed = list(run)
    for name in SNAPSHOT_FIELDS:  # the frames before the checkpoint are kept
        assert np.array_equal(getattr(resumed[1], name), getattr(frames[1], name)), name
    # frame 2 is the uninterrupted run's: bit for bit on the machine that wrote the files, and on
    # another CPU within its last-bit differences amplified over 700 steps (the tolerances of the
    # reference trajectory above)
    a, b = resumed[2], frames[2]
    d = sim.params.d_mean
    assert a.step == b.step and a.time == b.time and np.array_equal(a.ids, b.ids)
    np.testing.assert_allclose(a.position, b.position, rtol=0, atol=1e-8 * d)
    np.testing.assert_allclose(a.velocity, b.velocity, rtol=0, atol=4e-8)
    np.testing.assert_allclose(a.angular_velocity, b.angular_velocity, rtol=0, atol=4e-8 / d)
    np.testing.assert_allclose(a.film_volume, b.film_volume, rtol=1e-9, atol=1e-9 * d**3)
    assert np.array_equal(a.contact_i, b.contact_i) and np.array_equal(a.contact_j, b.contact_j)


def test_an_earlier_versions_two_file_checkpoint_is_refused_naming_it(tmp_path):
    ckpt = tmp_path / "run.h5.ckpt.npz"
    np.savez(ckpt, position=np.zeros((2, 3)))
    with pytest.raises(ValueError, match="no 'checkpoint_info' inside"):
        read_checkpoint(ckpt)
    (tmp_path / "run.h5.ckpt.npz.json").write_text("{}")
    with pytest.raises(ValueError, match="run.h5.ckpt.npz.json beside it is the two-file checkpoint of an earlier version"):
        read_checkpoint(ckpt)


def test_resume_refuses_a_run_file_that_is_not_the_checkpoints(tmp_path):
    import os
    import shutil

    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    Simulation(RESUME_PARAMS, ORIGINAL).run(a, REVS / 3, frame_every=FRAME_EVERY, checkpoint_every=2, progress=False)
    other = dataclasses.replace(RESUME_PARAMS, seed=1)
    Simulation(other, dataclasses.replace(ORIGINAL, seed=1)).run(b, REVS / 3, frame_every=FRAME_EVERY,
                                                                   checkpoint_every=2, progress=False)
    shutil.copyfile(f"{a}.ckpt.npz", f"{b}.ckpt.npz")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    sim = resume_run(b)
    with pytest.raises(ValueError, match="different parameters.*seed"):
        sim.run(b, REVS, frame_every=FRAME_EVERY, checkpoint_every=2, progress=False, resume=True)
    with pytest.raises(ValueError, match="frame every 400 steps"):
        resume_run(a).run(a, REVS, frame_every=200, checkpoint_every=2, progress=False, resume=True)
    with pytest.raises(ValueError, match="past the end"):
        resume_run(a).run(a, REVS / 12, frame_every=FRAME_EVERY, checkpoint_every=2, progress=False, resume=True)
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
    os.unlink(a)
    with pytest.raises(ValueError, match="run file missing"):
        resume_run(a).run(a, REVS, frame_every=FRAME_EVERY, checkpoint_every=2, progress=False, resume=True)


def test_a_new_run_refuses_to_replace_a_file_unless_told(tmp_path):
    out = tmp_path / "r.h5"
    out.write_bytes(b"precious")
    sim = Simulation.from_particles(dataclasses.replace(RESUME_PARAMS, n_particles=2),
                                    [[0.0, -0.02, 0.01], [0.01, -0.02, 0.01]], [0.002, 0.002])
    with pytest.raises(FileExistsError, match="overwrite"):
        sim.run(out, REVS / 12, frame_every=FRAME_EVERY, progress=False)
    assert out.read_bytes() == b"precious"
    sim.run(out, REVS / 12, frame_every=FRAME_EVERY, progress=False, overwrite=True)
    with ga.open_run(out) as run:
        assert len(run) == 2


def test_a_run_ends_at_the_requested_revolutions(tmp_path):
    sim = Simulation.from_particles(dataclasses.replace(RESUME_PARAMS, n_particles=2),
                                    [[0.0, -0.02, 0.01], [0.01, -0.02, 0.01]], [0.002, 0.002])
    p = sim.params
    steps_per_rev = p.revolution_period / p.dt
    frame_every = int(round(0.0015 * steps_per_rev))  # 523.6 steps, rounded up to 524
    assert frame_every > 0.0015 * steps_per_rev
    assert sim.frame_plan(0.006, frame_every) == (frame_every, 5)
    with pytest.raises(ValueError, match="whole number of frame intervals"):
        sim.frame_plan(0.006, int(round(0.0025 * steps_per_rev)))
    for bad in (math.inf, math.nan, 0.0, -1.0):
        with pytest.raises(ValueError, match="revolutions"):
            sim.frame_plan(bad)
    with pytest.raises(ValueError, match="checkpoint_every"):
        sim.run(tmp_path / "r.h5", 0.006, frame_every=frame_every, checkpoint_every=0, progress=False)
    sim.run(tmp_path / "r.h5", 0.006, frame_every=frame_every, progress=False)
    with ga.open_run(tmp_path / "r.h5") as run:
        assert len(run) == 5
        assert abs(run.steps[-1] - 0.006 * steps_per_rev) <= 2.5  # the requested end, to the rounding of the interval
        # the run records the frames it planned: a reader tells it from a killed one
        assert run.meta.provenance["planned_frames"] == 5 and run.unfinished is None
    # a run whose frames cannot fit on the disk is refused before it starts, naming the size
    with pytest.raises(ga.ParameterError, match="would need about .* of disk"):
        sim.run(tmp_path / "huge.h5", 0.0015 * 10**12, frame_every=frame_every, progress=False)
    assert not (tmp_path / "huge.h5").exists()
    kept = ga.subset_run(tmp_path / "r.h5", tmp_path / "sub.h5", frames=[0, 2, 4])
    with ga.open_run(kept) as run:  # a subset plans the frames it keeps
        assert run.meta.provenance["planned_frames"] == 3 and run.unfinished is None


def test_resume_refuses_a_checkpoint_of_another_physics_version(tmp_path):
    import json

    from sim.run import PHYSICS_VERSION

    out = tmp_path / "a.h5"
    Simulation(RESUME_PARAMS, ORIGINAL).run(out, REVS / 3, frame_every=FRAME_EVERY, checkpoint_every=2, progress=False)
    with ga.open_run(out) as run:
        assert run.meta.provenance["physics_version"] == PHYSICS_VERSION
    ckpt = f"{out}.ckpt.npz"
    with np.load(ckpt) as data:
        arrays = {name: data[name] for name in data.files}
    info = json.loads(str(arrays["checkpoint_info"]))
    assert info["physics_version"] == PHYSICS_VERSION

    def rewrite(version):
        changed = dict(info)
        if version is None:
            del changed["physics_version"]
        else:
            changed["physics_version"] = version
        np.savez(ckpt, **{**arrays, "checkpoint_info": np.array(json.dumps(changed))})

    rewrite(PHYSICS_VERSION - 1)
    before = out.read_bytes()
    with pytest.raises(ValueError, match=f"physics version {PHYSICS_VERSION - 1}.*--overwrite"):
        resume_run(out).run(out, REVS, frame_every=FRAME_EVERY, checkpoint_every=2, progress=False, resume=True)
    assert out.read_bytes() == before
    rewrite(None)  # written before versions were recorded: resumed, with a warning
    with pytest.warns(UserWarning, match="records no physics version"):
        resume_run(out).run(out, REVS / 3 + REVS / 12, frame_every=FRAME_EVERY, checkpoint_every=2,
                                   progress=False, resume=True)


@pytest.mark.parametrize("key, value", [("wall_s", "12"), ("wall_s", float("nan")), ("wall_s", None),
                                        ("cpu_s", -1.0), ("cpu_s", True), ("cpu_s", float("inf"))])
def test_a_checkpoint_with_a_damaged_time_is_refused_naming_it(tmp_path, key, value):
    import json

    out = tmp_path / "a.h5"
    Simulation(RESUME_PARAMS, ORIGINAL).run(out, REVS / 3, frame_every=FRAME_EVERY, checkpoint_every=2, progress=False)
    ckpt = f"{out}.ckpt.npz"
    with np.load(ckpt) as data:
        arrays = {name: data[name] for name in data.files}
    info = json.loads(str(arrays["checkpoint_info"]))
    np.savez(ckpt, **{**arrays, "checkpoint_info": np.array(json.dumps({**info, key: value}))})
    with pytest.raises(ValueError, match=f"{ckpt}: damaged checkpoint \\({key} is .*not a time in seconds"):
        resume_run(out)


def test_resuming_a_finished_run_leaves_its_file_as_it_is(tmp_path, capsys):
    params = dataclasses.replace(SMALL, settle_time=0.01)
    frame_every = 400
    revs = 4 * frame_every * params.dt / params.revolution_period  # 4 frames after the first
    out = tmp_path / "run.h5"
    Simulation(params, ORIGINAL).run(out, revs, frame_every=frame_every, checkpoint_every=2, progress=False)
    before = out.read_bytes()
    # the last checkpoint is after frame 4 of 5: a resume would otherwise simulate the last one again
    sim = resume_run(out)
    assert sim.resume_point.frames == 4
    step = sim.state.step
    sim.run(out, revs, frame_every=frame_every, checkpoint_every=2, progress=False, resume=True)
    assert out.read_bytes() == before
    assert "finished already" in capsys.readouterr().err
    assert sim.state.step == step  # nothing simulated
    # asking for more revolutions does resume
    resume_run(out).run(out, revs * 6 / 4, frame_every=frame_every, checkpoint_every=2, progress=False,
                               resume=True)
    with ga.open_run(out) as run:
        assert len(run) == 7


def test_fixed_bridge_volume_run_wets_the_settled_bed_and_never_sprays():
    v_fixed = 0.02 * SMALL.r_mean**3
    params = dataclasses.replace(SMALL, bridge_volume=v_fixed)
    sim = Simulation(params, ORIGINAL)
    s = sim.state
    assert s.alive.any() and np.all(s.v_b[s.alive] == v_fixed)  # the touching pairs of the dry bed get V_b
    assert not s.film.any()
    sim.advance(int(3 * params.spray_interval / params.dt))  # past three spray times
    assert not s.film.any() and s.sprayed_total == 0.0
    assert np.all(s.v_b[s.alive] == v_fixed)  # every bridge, old or new, particle or wall


def test_dry_walls_give_no_wall_contact_a_bridge_and_leave_the_pairs_wet():
    v_fixed = 0.02 * SMALL.r_mean**3
    with pytest.raises(ValueError, match="wall_bridges=False needs the fixed-bridge-volume model"):
        dataclasses.replace(SMALL, wall_bridges=False)
    wet, dry = (Simulation(dataclasses.replace(SMALL, bridge_volume=v_fixed, wall_bridges=walls), ORIGINAL)
                for walls in (True, False))
    for sim in (wet, dry):
        sim.advance(int(0.02 / sim.params.dt))
    n_wall_slots = wet.state.n_particles * wet.n_walls
    for sim, wall_volume in ((wet, v_fixed), (dry, 0.0)):
        s = sim.state
        walls, pairs = s.alive[:n_wall_slots], s.alive[n_wall_slots:]
        assert walls.sum() > 10 and pairs.sum() > 10  # the bed lies on the walls in both
        assert np.all(s.v_b[:n_wall_slots][walls] == wall_volume)
        assert np.all(s.v_b[n_wall_slots:][pairs] == v_fixed)
    # a dry wall contact ends at separation: no wall slot of the dry run is alive with a gap
    assert not np.any(dry.state.alive[:n_wall_slots] & (dry.state.gap[:n_wall_slots] > 0))
    assert np.any(wet.state.alive[:n_wall_slots] & (wet.state.gap[:n_wall_slots] > 0))


if __name__ == "__main__":  # regenerate tests/data/reference_trajectory.npz (an intentional change of physics)
    np.savez(REFERENCE_TRAJECTORY, **{f"{config}_{name}": value for config in TRAJECTORY_CONFIGS
                                      for name, value in _trajectory_end(config).items()})
    print(f"wrote {REFERENCE_TRAJECTORY}")
