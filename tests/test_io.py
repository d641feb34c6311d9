import os
import signal
import subprocess
import sys
import textwrap
import time

import h5py
import numpy as np
import pytest

from granalytics import RunFileError, RunWriter, ValidationError, open_run
from granalytics.core.snapshot import CONTACT_FIELDS, PARTICLE_FIELDS
from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot

def assert_same_frame(a, b):
    assert a.time == b.time and a.step == b.step
    for name in PARTICLE_FIELDS + CONTACT_FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)

@pytest.fixture
def frames():
    meta = synthetic_meta(400)
    return [synthetic_snapshot(400, time=0.5 * k, step=100 * k, seed=k, meta=meta,
                               contacts_per_particle=1.0 + 0.5 * k) for k in range(5)]

@pytest.fixture
def run_path(tmp_path, frames):
    path = tmp_path / "run.h5"
    with RunWriter(path, frames[0].meta) as writer:
        for s in frames:
            writer.append(s)
    return path

def test_round_trip_is_exact_and_keeps_metadata(run_path, frames):
    with open_run(run_path) as run:
        assert len(run) == 5 and run.n_particles == 400
        assert run.meta == frames[0].meta
        for read, written in zip(run, frames):
            assert_same_frame(read, written)
            assert read.meta == written.meta
        assert np.array_equal(run.n_contacts, [s.n_contacts for s in frames])

def test_lazy_indexing_slicing_and_selection(run_path, frames):
    with open_run(run_path) as run:
        assert_same_frame(run[-1], frames[4])
        part = run[1:4]
        assert len(part) == 3 and np.array_equal(part.frame_indices, [1, 2, 3])
        assert_same_frame(part[1], frames[2])
        assert_same_frame(part[::2][1], frames[3])
        sel = run.select(time=(0.4, 1.6))
        assert np.array_equal(sel.times, [0.5, 1.0, 1.5])
        period = 2 * np.pi / 2.0
        by_rev = run.select(revolutions=(0.9 / period, 1.1 / period))
        assert np.array_equal(by_rev.times, [1.0])
        assert run.nearest(time=1.26).time == 1.5
        assert run.nearest(revolutions=0.0).time == 0.0
        with pytest.raises(IndexError):
            run[5]
        with pytest.raises(ValidationError, match="exactly one"):
            run.select()
        assert len(run.select(time=(10, 11))) == 0
        # a frame within a tenth of the 0.5 s spacing of an edge is inside, one a fifth away is not
        assert np.array_equal(run.select(time=(0.54, 1.46)).times, [0.5, 1.0, 1.5])
        assert np.array_equal(run.select(time=(0.6, 1.4)).times, [1.0])

def test_writer_rejects_changing_particle_count_time_order_and_existing_file(tmp_path, frames):
    path = tmp_path / "w.h5"
    with RunWriter(path, frames[0].meta) as writer:
        writer.append(frames[1])
        with pytest.raises(ValidationError, match="must increase"):
            writer.append(frames[0])
        other = synthetic_snapshot(401, time=9.0)
        with pytest.raises(ValidationError, match="particle count changed"):
            writer.append(other)
        assert writer.n_frames == 1
    with pytest.raises(RunFileError, match="exists"):
        RunWriter(path, frames[0].meta)
    with pytest.raises(ValidationError, match="meta.n_particles"):
        with RunWriter(tmp_path / "x.h5", synthetic_meta(10)) as writer:
            writer.append(frames[0])

def test_writer_sync_puts_the_committed_frames_on_disk(tmp_path, frames, monkeypatch):
    import granalytics.core.writer as writer_module

    synced = []
    real_fsync = writer_module.os.fsync
    monkeypatch.setattr(writer_module.os, "fsync", lambda fd: (synced.append(os.readlink(f"/proc/self/fd/{fd}")),
                                                               real_fsync(fd)))
    path = tmp_path / "w.h5"
    with RunWriter(path, frames[0].meta) as writer:
        writer.append(frames[0])
        writer.sync()
        assert synced == [str(path)]
        with open_run(path) as run:  # a reader sees the synced frame while the writer is open
            assert len(run) == 1
    with pytest.raises(RunFileError, match="writer is closed"):
        writer.sync()

def test_file_without_frames_reads_as_empty_run(tmp_path, frames):
    path = tmp_path / "empty.h5"
    RunWriter(path, frames[0].meta).close()
    with open_run(path) as run:
        assert len(run) == 0 and list(run) == []

def test_missing_not_hdf5_and_truncated_files_raise_run_file_error(tmp_path, run_path):
    with pytest.raises(RunFileError, match="no such file"):
        open_run(tmp_path / "nope.h5")
    text = tmp_path / "text.h5"
    text.write_text("hello")
    with pytest.raises(RunFileError, match="cannot read as HDF5"):
        open_run(text)
    data = run_path.read_bytes()
    cut = tmp_path / "cut.h5"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(RunFileError, match=str(cut)):
        open_run(cut)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = 1
    with pytest.raises(RunFileError, match="not a granalytics run"):
        open_run(other)

def test_corrupt_values_in_a_file_name_file_frame_field_and_index(run_path):
    with h5py.File(run_path, "r+") as f:
        f["particles/position"][3, 17, 1] = np.nan
        start = int(f["contacts/count"][:1].sum())
        f["contacts/j"][start + 5] = 10_000
    with open_run(run_path) as run:
        with pytest.raises(ValidationError) as err:
            run[3]
        msg = str(err.value)
        assert str(run_path) in msg and "frame 3" in msg and "'position'" in msg and "index 17" in msg
        with pytest.raises(ValidationError, match="frame 1, field 'contact_j', index 5: particle index 10000 out of range"):
            run[1]
        run[0]  # untouched frames still read

#: a writer appending frames until it is killed: python -c WRITER PATH [N_PARTICLES]
WRITER = textwrap.dedent(
    """
    import sys
    from granalytics import RunWriter
    from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 20000
    meta = synthetic_meta(n)
    base = [synthetic_snapshot(n, seed=s, meta=meta) for s in range(3)]
    with RunWriter(sys.argv[1], meta) as writer:
        k = 0
        while True:
            frame = base[k % 3]
            frame.time, frame.step = 0.01 * k, k
            writer.append(frame)
            print(k, flush=True)
            k += 1
    """
)

def test_sigkilled_writer_leaves_every_complete_frame_readable(tmp_path):
    meta = synthetic_meta(20000)
    base = [synthetic_snapshot(20000, seed=s, meta=meta) for s in range(3)]
    rng = np.random.default_rng(7)
    mid_frame_kills = 0
    for trial in range(6):
        path = tmp_path / f"killed{trial}.h5"
        proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], stdout=subprocess.PIPE, text=True)
        reported = int(proc.stdout.readline())  # the first frame is committed
        time.sleep(rng.uniform(0.05, 0.6))
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        lines = proc.stdout.read().split()
        reported = max([reported] + [int(x) for x in lines])
        with open_run(path) as run:
            n = len(run)
            assert n >= reported + 1  # every frame the writer reported as committed
            for k, snapshot in enumerate(run):
                frame = base[k % 3]
                assert snapshot.time == 0.01 * k and snapshot.step == k
                for name in PARTICLE_FIELDS + CONTACT_FIELDS:
                    np.testing.assert_array_equal(getattr(snapshot, name), getattr(frame, name), err_msg=name)
        with h5py.File(path, "r", swmr=True) as f:  # was the writer killed inside a frame?
            longest = max(len(f["particles"][name]) for name in PARTICLE_FIELDS)
            rows = min(len(f["contacts"][name]) for name in ("i", "j", "f_cap", "f_normal", "gap", "bridge_volume"))
            committed_rows = sum(base[k % 3].n_contacts for k in range(n))
            mid_frame_kills += longest > n or rows > committed_rows
        if trial >= 2 and mid_frame_kills:
            break
    assert mid_frame_kills, "no kill landed inside a frame: the test did not exercise partial frames"


def test_every_dataset_of_a_run_file_states_its_unit(run_path):
    """docs/format.md: units on every dataset (`/contacts/count` had none)."""
    missing = []
    with h5py.File(run_path, "r") as f:
        f.visititems(lambda name, obj: missing.append(name)
                     if isinstance(obj, h5py.Dataset) and "unit" not in obj.attrs else None)
    assert missing == []
