"""Run files under stress: one writer at a time (lock file), files cut by a killed writer or an
interrupted copy, damaged chunks and edited index datasets, and continue_from."""

import json
import os
import signal
import socket
import subprocess
import sys
import textwrap
import time

import h5py
import numpy as np
import pytest

import granalytics
from granalytics import GranalyticsError, ParameterError, RunFileError, RunWriter, ValidationError, WriterLock, open_run
from granalytics.cli import main
from granalytics.base.errors import RunLockedError
from granalytics.core.snapshot import CONTACT_FIELDS, PARTICLE_FIELDS
from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot

from test_io import WRITER  # a writer appending frames until it is killed
from conftest import expects_small_run_warnings

N = 300
# child processes import the granalytics under test
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join(
    [os.path.dirname(os.path.dirname(granalytics.__file__))] + os.environ.get("PYTHONPATH", "").split(os.pathsep))}


def make_frames(n_frames=5, n=N, steps=True):
    meta = synthetic_meta(n)
    return [synthetic_snapshot(n, time=0.5 * k, step=100 * k if steps else 0, seed=k, meta=meta,
                               contacts_per_particle=1.0 + 0.5 * k) for k in range(n_frames)]


def write_run(path, frames, **kwargs):
    with RunWriter(path, frames[0].meta, **kwargs) as writer:
        for s in frames:
            writer.append(s)
    return path


def assert_same_frame(a, b):
    assert a.time == b.time and a.step == b.step
    for name in PARTICLE_FIELDS + CONTACT_FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def one_line(exc):
    text = str(exc)
    assert "\n" not in text, text
    return text


@pytest.fixture
def frames():
    return make_frames()


@pytest.fixture
def run_path(tmp_path, frames):
    return write_run(tmp_path / "run.h5", frames)


# ---------------------------------------------------------------------------------------- lock file

def test_second_writer_in_the_same_process_is_refused_until_the_first_closes(tmp_path, frames):
    path = tmp_path / "run.h5"
    lock = tmp_path / "run.h5.lock"
    first = RunWriter(path, frames[0].meta)
    first.append(frames[0])
    owner = json.loads(lock.read_text())
    assert owner["pid"] == os.getpid() and owner["host"] == socket.gethostname()
    assert first.lock_path == str(lock)
    for kwargs in ({}, {"overwrite": True}):
        with pytest.raises(RunLockedError) as err:
            RunWriter(path, frames[0].meta, **kwargs)
        msg = one_line(err.value)
        assert str(path) in msg and str(lock) in msg and f"pid {os.getpid()}" in msg
        assert isinstance(err.value, RunFileError)
    first.append(frames[1])  # the refused writers did not touch the file
    first.close()
    assert not lock.exists()
    with open_run(path) as run:
        assert len(run) == 2
        assert_same_frame(run[1], frames[1])
    with RunWriter(path, frames[0].meta, overwrite=True) as second:  # free again
        second.append(frames[0])
    assert not lock.exists()


def test_a_locked_file_is_not_truncated(run_path, frames):
    before = run_path.read_bytes()
    lock = run_path.with_name("run.h5.lock")
    with WriterLock(run_path):  # another writer of this process holds it
        with pytest.raises(RunLockedError):
            RunWriter(run_path, frames[0].meta, overwrite=True)
        assert run_path.read_bytes() == before  # the lock comes before the file is truncated
        assert lock.exists()  # someone else's lock is left alone


HOLDER = textwrap.dedent(
    """
    import sys
    from granalytics import RunWriter
    from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot
    meta = synthetic_meta(50)
    with RunWriter(sys.argv[1], meta, overwrite=True) as writer:
        writer.append(synthetic_snapshot(50, seed=1, meta=meta))
        print("ready", flush=True)
        sys.stdin.readline()
    print("closed", flush=True)
    """
)


def test_writer_in_another_process_blocks_this_one_and_the_cli_exits_2(tmp_path, frames, capsys):
    path = tmp_path / "run.h5"
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(path)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, env=ENV)
    try:
        assert proc.stdout.readline().strip() == "ready"
        with pytest.raises(RunLockedError) as err:
            RunWriter(path, frames[0].meta, overwrite=True)
        msg = one_line(err.value)
        assert str(path) in msg and f"{path}.lock" in msg and f"pid {proc.pid}" in msg
        src = write_run(tmp_path / "src.h5", frames)
        assert main(["subset", str(src), "--out", str(path), "--overwrite", "--quiet"]) == 2
        stderr = capsys.readouterr().err.strip()
        assert "\n" not in stderr and f"{path}.lock" in stderr and "another writer" in stderr
    finally:
        proc.stdin.write("\n")
        proc.stdin.close()
        assert proc.stdout.readline().strip() == "closed"
        proc.wait(timeout=60)
    assert not (tmp_path / "run.h5.lock").exists()
    with open_run(path) as run:
        assert len(run) == 1 and run.n_particles == 50


def test_a_killed_writers_lock_file_is_not_in_the_way(tmp_path, frames):
    """kill -9 leaves the lock file behind, but the operating system released its lock: the next
    writer takes it without asking; a lock file that nobody holds says nothing either way."""
    path = tmp_path / "run.h5"
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(path)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, env=ENV)
    assert proc.stdout.readline().strip() == "ready"
    proc.kill()
    proc.wait(timeout=60)
    lock = tmp_path / "run.h5.lock"
    assert json.loads(lock.read_text())["pid"] == proc.pid  # left behind
    with RunWriter(path, frames[0].meta, overwrite=True) as writer:
        assert json.loads(lock.read_text())["pid"] == os.getpid()
        writer.append(frames[0])
    assert not lock.exists()
    lock.write_text("not a lock")
    with RunWriter(path, frames[0].meta, overwrite=True) as writer:
        writer.append(frames[1])
    with open_run(path) as run:
        assert len(run) == 1 and run[0].step == frames[1].step


def test_lock_is_held_through_compaction_and_released_after_errors(tmp_path, frames, monkeypatch):
    path = tmp_path / "run.h5"
    seen = []
    compact = RunWriter._compact

    def spy(self):
        seen.append(json.loads(open(self.lock_path).read())["pid"])
        compact(self)

    monkeypatch.setattr(RunWriter, "_compact", spy)
    write_run(path, frames[:2])
    assert seen == [os.getpid()] and not os.path.exists(f"{path}.lock")
    # creating the HDF5 file fails: the lock goes too
    def cannot_create(*args, **kwargs):
        raise OSError(28, "No space left on device")

    with monkeypatch.context() as patch:
        patch.setattr(h5py, "File", cannot_create)
        with pytest.raises(RunFileError, match="cannot create run file"):
            RunWriter(tmp_path / "full.h5", frames[0].meta, overwrite=True)
    assert not os.path.exists(tmp_path / "full.h5.lock")
    # a folder in the way is refused before any lock file is made
    folder = tmp_path / "folder.h5"
    folder.mkdir()
    with pytest.raises(GranalyticsError, match="is a folder"):
        RunWriter(folder, frames[0].meta, overwrite=True)
    assert not os.path.exists(f"{folder}.lock")
    with pytest.raises(RunFileError, match="lock file"):
        RunWriter(tmp_path / "missing" / "run.h5", frames[0].meta)


def test_interrupted_append_leaves_a_consistent_file(tmp_path, frames, monkeypatch):
    path = tmp_path / "run.h5"
    calls = []
    append_scalar = RunWriter._append_scalar

    def interrupted(ds, frame, value):
        calls.append(frame)
        if frame == 2 and ds.name == "/contacts/count":
            raise KeyboardInterrupt
        append_scalar(ds, frame, value)

    monkeypatch.setattr(RunWriter, "_append_scalar", staticmethod(interrupted))
    with pytest.raises(KeyboardInterrupt):
        write_run(path, frames)
    assert not os.path.exists(f"{path}.lock")
    with open_run(path) as run:  # closed normally: checked strictly, and consistent
        assert len(run) == 2
        assert_same_frame(run[1], frames[1])


# ------------------------------------------------------------------- files cut by a killed writer


READ_ALL = textwrap.dedent(
    """
    import sys, time
    from granalytics import GranalyticsError, open_run
    t0 = time.perf_counter()
    try:
        with open_run(sys.argv[1]) as run:
            n = len(run)
            for frame in run:
                pass
        print("ok", n, time.perf_counter() - t0)
    except GranalyticsError as exc:
        print("error", time.perf_counter() - t0, type(exc).__name__, str(exc).replace(chr(10), "<NL>"))
    """
)


@pytest.fixture(scope="module")
def killed_run(tmp_path_factory):
    """A run whose writer was SIGKILLed after 6 frames: 'open for write' flag set."""
    path = tmp_path_factory.mktemp("killed") / "killed.h5"
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path), "2000"], stdout=subprocess.PIPE, text=True,
                            env=ENV)
    for _ in range(6):
        proc.stdout.readline()
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    with pytest.raises(OSError, match="already open for write"):
        h5py.File(path, "r")
    return path


def test_cut_files_open_or_fail_with_one_line_within_seconds(tmp_path, killed_run, run_path):
    data = killed_run.read_bytes()
    size = len(data)
    cuts = [("killed", k) for k in (100, 12_000, 20_000, size // 20, size // 3, size // 2, 9 * size // 10, size - 10)]
    closed = run_path.read_bytes()
    cuts += [("closed", k) for k in (5000, len(closed) // 2, len(closed) - 10)]
    outcomes = []
    for source, offset in cuts:
        cut = tmp_path / f"cut_{source}_{offset}.h5"
        cut.write_bytes((data if source == "killed" else closed)[:offset])
        t0 = time.monotonic()
        try:
            out = subprocess.run([sys.executable, "-c", READ_ALL, str(cut)], capture_output=True, text=True,
                                 timeout=10 + 5, env=ENV)  # 10 s for the open, 5 s to start Python
        except subprocess.TimeoutExpired:
            pytest.fail(f"{cut}: open_run did not return within {time.monotonic() - t0:.0f} s")
        assert out.returncode == 0, out.stderr[-2000:]
        word, seconds, *rest = out.stdout.split(maxsplit=3)
        if word == "ok":
            seconds = rest[0]
        assert float(seconds) < 10, (cut, out.stdout)
        if word == "error":
            kind, message = rest
            assert kind in ("RunFileError", "ValidationError") and str(cut) in message and "<NL>" not in message
        outcomes.append(word)
    assert outcomes.count("error") >= len(cuts) - 2  # (the last bytes may belong to a partial frame)
    with open_run(killed_run) as run:  # the uncut file still reads
        assert len(run) >= 6


def test_info_on_a_cut_file_exits_2_quickly(tmp_path, killed_run):
    cut = tmp_path / "cut.h5"
    cut.write_bytes(killed_run.read_bytes()[:20_000])
    try:
        out = subprocess.run([sys.executable, "-m", "granalytics", "info", str(cut)], capture_output=True,
                             text=True, timeout=10 + 10, env=ENV)
    except subprocess.TimeoutExpired:
        pytest.fail("granalytics info did not return")
    assert out.returncode == 2
    err = out.stderr.strip()
    assert "\n" not in err and str(cut) in err and "Traceback" not in err


def test_closed_file_cut_short_names_the_sizes(tmp_path, run_path):
    cut = tmp_path / "cut.h5"
    data = run_path.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(RunFileError, match=rf"{cut}: the file was cut short: {len(data) // 2} bytes, .*records {len(data)}"):
        open_run(cut)


# ---------------------------------------------------------------- checksums and the frame index

def chunk_span(path, name, coord):
    with h5py.File(path, "r") as f:
        info = f[name].id.get_chunk_info_by_coord(coord)
        return info.byte_offset, info.size


def flip_byte(path, offset):
    with open(path, "r+b") as f:
        f.seek(offset)
        byte = f.read(1)
        f.seek(offset)
        f.write(bytes([byte[0] ^ 0x10]))


@pytest.mark.parametrize("kwargs", [{}, {"compression": None}, {"compression": "lzf", "float_dtype": "float32"}])
def test_every_dataset_has_a_checksum(tmp_path, frames, kwargs):
    path = write_run(tmp_path / "run.h5", frames, **kwargs)
    names = []
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: names.append(name) if isinstance(obj, h5py.Dataset) else None)
        assert len(names) == 3 + len(PARTICLE_FIELDS) + len(CONTACT_FIELDS)
        assert all(f[name].fletcher32 for name in names), [n for n in names if not f[n].fletcher32]


def test_damaged_particle_chunk_names_file_dataset_and_frame(run_path, frames):
    offset, size = chunk_span(run_path, "particles/position", (3, 0, 0))
    flip_byte(run_path, offset + size // 2)
    with open_run(run_path) as run:
        with pytest.raises(RunFileError) as err:
            run[3]
        msg = one_line(err.value)
        assert str(run_path) in msg and "dataset /particles/position" in msg and "frame 3" in msg
        assert_same_frame(run[2], frames[2])
        assert_same_frame(run[4], frames[4])


def test_damaged_contact_chunk_names_the_dataset(run_path):
    offset, size = chunk_span(run_path, "contacts/f_cap", (0,))
    flip_byte(run_path, offset + 3)
    with open_run(run_path) as run:
        with pytest.raises(RunFileError, match=r"dataset /contacts/f_cap, frame 0"):
            run[0]


def test_bit_flip_in_frame_time_is_refused_on_open(run_path):
    offset, _size = chunk_span(run_path, "frames/time", (0,))
    flip_byte(run_path, offset + 8 * 3 + 6)  # frame 3's time, a high mantissa byte
    with pytest.raises(RunFileError) as err:
        open_run(run_path)
    assert str(run_path) in one_line(err.value) and "dataset /frames/time, frames 0-4" in str(err.value)


def edit(path, fn):
    with h5py.File(path, "r+") as f:
        fn(f)


def test_changed_contact_count_is_refused(run_path, frames, capsys):
    edit(run_path, lambda f: f["contacts/count"].__setitem__(1, f["contacts/count"][1] - 1))
    with pytest.raises(ValidationError) as err:
        open_run(run_path)
    msg = one_line(err.value)
    assert str(run_path) in msg and "dataset '/contacts/count'" in msg and "contact rows" in msg
    assert main(["stats", str(run_path), "--quiet"]) == 2
    assert "/contacts/count" in capsys.readouterr().err


@pytest.mark.parametrize("dataset, index, fn", [
    ("/frames/time", 3, lambda f: f["frames/time"].__setitem__(3, f["frames/time"][1])),
    ("/frames/time", 4, lambda f: f["frames/time"].__setitem__(4, np.nan)),
    ("/frames/step", 2, lambda f: f["frames/step"].__setitem__(2, f["frames/step"][1])),
    ("/frames/step", 1, lambda f: f["frames/step"].__setitem__(1, -5)),
])
def test_time_and_step_must_increase(run_path, dataset, index, fn):
    edit(run_path, fn)
    with pytest.raises(ValidationError) as err:
        open_run(run_path)
    assert err.value.field == dataset and err.value.index == index and err.value.path == str(run_path)
    assert f"dataset '{dataset}', index {index}" in one_line(err.value)


def test_constant_steps_mean_not_recorded_and_are_allowed(tmp_path):
    frames = make_frames(3, steps=False)
    path = write_run(tmp_path / "r.h5", frames)
    with open_run(path) as run:
        assert list(run.steps) == [0, 0, 0]
    later = make_frames(3)
    with RunWriter(tmp_path / "x.h5", frames[0].meta) as writer:
        writer.append(frames[0])
        writer.append(frames[1])
        with pytest.raises(ValidationError, match="step"):
            writer.append(later[2])  # 0, 0, 200: neither increasing nor constant
    with RunWriter(tmp_path / "y.h5", frames[0].meta) as writer:
        writer.append(later[0])
        writer.append(later[1])
        with pytest.raises(ValidationError, match="step"):
            writer.append(synthetic_snapshot(N, time=5.0, step=100, meta=frames[0].meta))


def test_meta_n_particles_must_match_the_particle_arrays(run_path):
    edit(run_path, lambda f: f["meta"].attrs.__setitem__("n_particles", np.int64(2100)))
    with pytest.raises(ValidationError) as err:
        open_run(run_path)
    msg = one_line(err.value)
    assert str(run_path) in msg and "n_particles is 2100" in msg and f"/particles/radius holds {N}" in msg


@pytest.mark.parametrize("name", ["frames/step", "particles/velocity", "contacts/count"])
def test_per_frame_datasets_must_have_one_entry_per_frame(run_path, name):
    edit(run_path, lambda f: f[name].resize(4, axis=0))
    with pytest.raises(RunFileError) as err:
        open_run(run_path)
    msg = one_line(err.value)
    assert str(run_path) in msg and f"dataset /{name}, index 4" in msg


def test_contact_datasets_must_have_the_same_length(run_path):
    edit(run_path, lambda f: f["contacts/gap"].resize(f["contacts/gap"].shape[0] - 3, axis=0))
    with pytest.raises(RunFileError, match=r"dataset /contacts/gap, index \d+: holds"):
        open_run(run_path)


def without_checksums(src, dst):
    """The file as an older writer made it: same layout, no Fletcher-32 filter."""
    with h5py.File(src, "r") as a, h5py.File(dst, "w", libver="latest") as b:
        for key, value in a.attrs.items():
            b.attrs[key] = value

        def copy(name, obj):
            if isinstance(obj, h5py.Group):
                group = b.require_group(name)
                for key, value in obj.attrs.items():
                    group.attrs[key] = value
            else:
                ds = b.create_dataset(name, data=obj[()], chunks=obj.chunks, maxshape=obj.maxshape,
                                      compression=obj.compression, shuffle=obj.shuffle)
                for key, value in obj.attrs.items():
                    ds.attrs[key] = value

        a.visititems(copy)
    return dst


def test_older_files_without_checksums_still_open(tmp_path, run_path, frames):
    old = without_checksums(run_path, tmp_path / "old.h5")
    with h5py.File(old, "r") as f:
        assert not f["particles/position"].fletcher32 and not f["frames/time"].fletcher32
    with open_run(old) as run:
        assert len(run) == 5
        for read, written in zip(run, frames):
            assert_same_frame(read, written)
    edit(old, lambda f: f["contacts/count"].__setitem__(2, f["contacts/count"][2] + 4))
    with pytest.raises(ValidationError, match="/contacts/count"):  # the index checks apply too
        open_run(old)


# ------------------------------------------------------------------------------- continue_from

def test_continue_from_keeps_storage_metadata_and_frames(tmp_path, frames):
    meta = frames[0].meta
    meta.provenance = {**meta.provenance, "note": "first sitting"}
    path = write_run(tmp_path / "run.h5", frames, compression="lzf", float_dtype="float32")
    with h5py.File(path, "r") as f:
        attrs = dict(f.attrs)
        meta_attrs = dict(f["meta"].attrs)
    with open_run(path) as run:
        stored = list(run)
    writer = RunWriter.continue_from(path, 3)
    with pytest.raises(RunLockedError):  # continue_from writes under the run's lock
        RunWriter(path, meta, overwrite=True)
    with pytest.raises(RunLockedError):
        RunWriter.continue_from(path, 3)
    assert writer.n_frames == 3
    writer.append(stored[4])
    writer.close()
    assert not os.path.exists(f"{path}.lock") and not os.path.exists(f"{path}.continue.tmp")
    with h5py.File(path, "r") as f:
        assert dict(f.attrs) == attrs
        assert {k: str(v) for k, v in f["meta"].attrs.items()} == {k: str(v) for k, v in meta_attrs.items()}
        ds = f["particles/position"]
        assert ds.dtype == np.float32 and ds.compression == "lzf" and ds.fletcher32
    with open_run(path) as run:
        assert len(run) == 4
        for k, read in enumerate(run):
            assert_same_frame(read, stored[[0, 1, 2, 4][k]])


@pytest.mark.parametrize("n_frames, error, words", [
    (6, RunFileError, "holds 5 complete frames"),
    (-1, ParameterError, "^RunWriter.continue_from: n_frames must be a whole number >= 0, got int -1$"),
    (True, ParameterError, "^RunWriter.continue_from: n_frames must be a whole number >= 0, got bool True$"),
    (2.5, ParameterError, "^RunWriter.continue_from: n_frames must be a whole number >= 0, got float 2.5$"),
])
def test_continue_from_refuses_bad_frame_counts_and_leaves_the_file_alone(run_path, n_frames, error, words):
    before = run_path.read_bytes()
    with pytest.raises(error, match=words):
        RunWriter.continue_from(run_path, n_frames)
    assert run_path.read_bytes() == before
    assert sorted(os.listdir(run_path.parent)) == ["run.h5"]  # no lock, no temporary file


def test_continue_from_a_missing_or_locked_file(tmp_path, run_path, frames):
    with pytest.raises(RunFileError, match="no such file"):
        RunWriter.continue_from(tmp_path / "nope.h5", 0)
    assert not os.path.exists(tmp_path / "nope.h5.lock")
    before = run_path.read_bytes()
    with WriterLock(run_path):
        with pytest.raises(RunLockedError):
            RunWriter.continue_from(run_path, 2)
    assert run_path.read_bytes() == before
    with RunWriter.continue_from(run_path, 0) as writer:
        writer.append(frames[0])
    with open_run(run_path) as run:
        assert len(run) == 1


def test_continue_from_a_killed_writers_file_is_not_held_by_its_lock(tmp_path, killed_run):
    owner = json.loads(open(f"{killed_run}.lock").read())  # a killed writer leaves its lock file behind
    path = tmp_path / "k.h5"
    path.write_bytes(killed_run.read_bytes())
    path.with_name("k.h5.lock").write_bytes(open(f"{killed_run}.lock", "rb").read())  # the fixture keeps its own
    assert owner["pid"] != os.getpid()
    RunWriter.continue_from(path, 4).close()  # the operating system released the lock when it died
    assert not os.path.exists(f"{path}.lock")
    path.write_bytes(killed_run.read_bytes())
    with pytest.raises(OSError):
        h5py.File(path, "r")  # flagged 'open for write'
    with open_run(path) as run:
        first = [run[k] for k in range(4)]
    with RunWriter.continue_from(path, 4) as writer:
        assert writer.n_frames == 4
    with open_run(path) as run:
        assert len(run) == 4
        for a, b in zip(run, first):
            assert_same_frame(a, b)


# -------------------------------------------------------------------------- metadata on writing

def test_metadata_changed_after_construction_is_checked_when_written(tmp_path, frames):
    meta = frames[0].meta
    loop = {}
    loop["self"] = loop
    meta.provenance = {"loop": loop}
    with pytest.raises(ValidationError, match="field 'provenance'"):
        RunWriter(tmp_path / "r.h5", meta)
    assert os.listdir(tmp_path) == []
    meta.provenance = {}
    with RunWriter(tmp_path / "r.h5", meta) as writer:
        with pytest.raises(ValidationError, match="field 'provenance'.*JSON"):
            writer.update_provenance(wall_time_s=np.int64(3))
        writer.update_provenance(wall_time_s=3.0)
    with open_run(tmp_path / "r.h5") as run:
        assert run.meta.provenance["wall_time_s"] == 3.0


def test_errors_are_granalytics_errors(run_path):
    edit(run_path, lambda f: f["frames/step"].resize(2, axis=0))
    with pytest.raises(GranalyticsError):
        open_run(run_path)


# ------------------------------------------------- mutated metadata (issue 33: round three, A1, A8)
def _mutated(tmp_path, run_path, name, change):
    path = tmp_path / f"{name}.h5"
    path.write_bytes(run_path.read_bytes())
    with h5py.File(path, "a") as f:
        change(f)
    return path


def _set_json(group, key, update):
    value = json.loads(group.attrs[key])
    update(value)
    group.attrs[key] = json.dumps(value)


@pytest.mark.parametrize("name, change, words", [
    ("format_ascii", lambda f: f.attrs.__setitem__("format", b"granalytics-run"), "'format'"),
    ("format_bytes_array", lambda f: f.attrs.__setitem__("format", np.array([b"granalytics-run"])), "'format'"),
    ("version_text", lambda f: f.attrs.__setitem__("format_version", "1"), "'format_version'"),
    ("version_float", lambda f: f.attrs.__setitem__("format_version", 1.5), "'format_version'"),
    ("version_bool", lambda f: f.attrs.__setitem__("format_version", True), "'format_version'"),
    ("density_text", lambda f: f["meta"].attrs.__setitem__("density", "2500"), "'density'"),
    ("gamma_bytes", lambda f: f["meta"].attrs.__setitem__("surface_tension", np.bytes_(b"0.1")), "'surface_tension'"),
    ("omega_bool", lambda f: f["meta"].attrs.__setitem__("drum_omega", True), "'drum_omega'"),
    ("capillary_text", lambda f: f["meta"].attrs.__setitem__("capillary_in_contact", "false"), "'capillary_in_contact'"),
    ("params_int", lambda f: f["meta"].attrs.__setitem__("sim_config", json.dumps({"params": 5})), "'sim_config.params'"),
    ("original_list", lambda f: f["meta"].attrs.__setitem__("sim_config", json.dumps({"original": [1]})),
     "'sim_config.original'"),
    ("params_capillary_text", lambda f: f["meta"].attrs.__setitem__(
        "sim_config", json.dumps({"params": {"capillary_in_contact": "false"}})), "'sim_config.params.capillary_in_contact'"),
    ("params_radius_text", lambda f: f["meta"].attrs.__setitem__(
        "sim_config", json.dumps({"params": {"drum_radius": "0.02"}})), "'sim_config.params.drum_radius'"),
    ("wall_time_text", lambda f: _set_json(f["meta"], "provenance", lambda p: p.update(wall_time_s="39 s")),
     "'provenance.wall_time_s'"),
    ("cpu_time_text", lambda f: _set_json(f["meta"], "provenance", lambda p: p.update(cpu_time_s="2 h")),
     "'provenance.cpu_time_s'"),
    ("provenance_number", lambda f: f["meta"].attrs.__setitem__("provenance", 5), "provenance"),
])
def test_mutated_metadata_is_refused_naming_the_attribute(tmp_path, run_path, capsys, name, change, words):
    """Each was read as a valid run by info, stats and subset (69 cases of round three): the text
    "false" as True (yield 0.88 instead of 0.34), "2500" as a density, an int as sim_config's table."""
    path = _mutated(tmp_path, run_path, name, change)
    with pytest.raises(GranalyticsError) as exc:
        open_run(path)
    assert words in one_line(exc.value) and str(path) in str(exc.value)
    for argv in (["info", str(path)], ["stats", str(path), "--quiet"],
                 ["subset", str(path), "--out", str(tmp_path / "s.h5")]):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("granalytics: error:") and "\n" not in err and words in err
    assert not (tmp_path / "s.h5").exists()


@expects_small_run_warnings
def test_a_null_wall_time_is_not_measured_in_compare_cg(tmp_path):
    """compare-cg raised TypeError: float() argument must be ... 'NoneType' on a run whose
    provenance records "wall_time_s": null."""
    from granalytics.datasets.synthetic import write_synthetic_run

    runs = []
    for alpha, n in ((1.0, 400), (2.0, 50)):
        path = write_synthetic_run(tmp_path / f"cg{alpha:g}.h5", n_particles=n, revolutions=2.0,
                                   frames_per_revolution=4, alpha=alpha, seed=1)
        with h5py.File(path, "a") as f:
            _set_json(f["meta"], "provenance", lambda p: p.update(wall_time_s=None, wall_time_per_simulated_s=None))
        runs.append(path)
    comparison = granalytics.compare_cg(runs, window=(1, 2))
    assert np.isnan(comparison.table["speedup"]).all()


# ------------------------------------------------------ a run left by a killed simulation (A3)
def test_info_and_stats_say_that_a_killed_writers_run_is_unfinished(killed_run, capsys):
    """info and stats showed a run whose writer was killed after 6 frames as a valid run."""
    with open_run(killed_run) as run:
        assert "did not close it" in run.unfinished
    assert main(["info", str(killed_run)]) == 0
    captured = capsys.readouterr()
    assert f"granalytics: warning: {killed_run}: unfinished run:" in captured.err
    assert "finished" in captured.out and "no: its writer did not close it" in captured.out
    assert main(["stats", str(killed_run), "--window-time", "0:100", "--quiet"]) == 0
    assert capsys.readouterr().err.count(f"{killed_run}: unfinished run: its writer did not close it") == 1


@pytest.mark.parametrize("provenance, words", [
    ({"code": "sim", "planned_frames": 11}, ["5 of the 11 frames planned", "no wall time"]),
    ({"code": "sim", "wall_time_s": 12.5, "planned_frames": 11}, ["5 of the 11 frames planned"]),
    ({"code": "sim"}, ["the simulator recorded no end (no wall time) after its 5 frames"]),
])
def test_a_run_stopped_before_its_planned_frames_is_unfinished(tmp_path, frames, provenance, words):
    frames[0].meta.provenance = provenance
    path = write_run(tmp_path / "run.h5", frames)
    with open_run(path) as run:
        assert all(w in run.unfinished for w in words), run.unfinished
    frames[0].meta.provenance = {"code": "sim", "wall_time_s": 1.0, "planned_frames": 5}
    with open_run(write_run(tmp_path / "done.h5", frames)) as run:
        assert run.unfinished is None


# ---------------------------------------------------------------------- resources (A4)
def test_a_small_file_declaring_2e8_particles_is_refused_at_once(tmp_path, run_path, capsys, monkeypatch):
    """450 kB declaring 2·10⁸ particles drove info/stats/subset past 8 GB of memory (the machine
    taken to have 16 GB, so that the test refuses on any machine)."""
    import granalytics.base.resources

    monkeypatch.setattr(granalytics.base.resources, "physical_memory", lambda: 16 * 10**9)
    n = 200_000_000
    path = tmp_path / "huge.h5"
    with h5py.File(path, "w") as f, h5py.File(run_path, "r") as src:
        for key, value in src.attrs.items():
            f.attrs[key] = value
        for group in ("meta", "frames", "contacts"):
            src.copy(group, f)
        f["meta"].attrs["n_particles"] = np.int64(n)
        f["meta"].attrs["n_particles_original"] = np.int64(n)
        for name, ds in src["particles"].items():  # declared, never written: fill values
            f.create_dataset(f"particles/{name}", shape=(ds.shape[0], n) + ds.shape[2:], dtype=ds.dtype,
                             chunks=(1, 1 << 20) + ds.shape[2:], compression="gzip")
    assert path.stat().st_size < 1_000_000
    for argv in (["info", str(path)], ["stats", str(path), "--quiet"],
                 ["subset", str(path), "--out", str(tmp_path / "s.h5")]):
        t0 = time.monotonic()
        assert main(argv) == 2
        assert time.monotonic() - t0 < 10
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and "200000000 particles" in err and "GB of memory" in err


def test_a_particle_set_that_changes_between_frames_is_refused(tmp_path):
    """Round four, B2: convert accepted frames with new or renumbered ids, and track then reported
    births and deaths of a granule that never changed. The writer, which every producer uses,
    refuses them."""
    import dataclasses

    from granalytics import RunWriter, ValidationError
    from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot

    meta = synthetic_meta(50)
    first = synthetic_snapshot(50, meta=meta, time=0.0, step=0)
    with RunWriter(tmp_path / "ok.h5", meta) as writer:
        writer.append(first)
        shuffled = np.random.default_rng(0).permutation(50)  # the same ids in another order: allowed
        writer.append(dataclasses.replace(first, time=1.0, step=1, ids=first.ids[shuffled]))
    renumbered = dataclasses.replace(first, time=1.0, step=1, ids=first.ids + 1000)
    with pytest.raises(ValidationError, match="the particle set changed: id 1000 is not in frame 0"):
        with RunWriter(tmp_path / "bad.h5", meta) as writer:
            writer.append(first)
            writer.append(renumbered)


@pytest.mark.parametrize("change, words", [
    ({"alpha": 1.0}, "attribute alpha is 1.0, but the simulator's parameters (sim_config.params) record 3.0"),
    ({"mean_radius": 0.75e-3}, "attribute mean_radius is 0.00075 m, but the particles of frame 0 have a mean radius"),
    ({"mean_radius": 2.3e-3}, None),  # within 10 % of lab-cg3's 2.25 mm: a nominal mean, accepted
])
def test_a_run_whose_records_contradict_each_other_is_refused_when_opened(tmp_path, change, words):
    import shutil

    import h5py

    import granalytics as ga
    from granalytics.datasets import dataset_path

    path = tmp_path / "relabelled.h5"
    shutil.copyfile(dataset_path("lab-cg3"), path)
    with h5py.File(path, "r+") as f:
        for key, value in change.items():
            f["meta"].attrs[key] = value
    if words is None:
        ga.open_run(path).close()
        return
    with pytest.raises(ga.ValidationError) as err:
        ga.open_run(path)
    assert words in str(err.value) and str(path) in str(err.value)
