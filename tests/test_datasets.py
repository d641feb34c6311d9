import shlex

import numpy as np
import pytest

import granalytics as ga
from granalytics import GranalyticsError
from granalytics.cli.datasets import main as _main
from granalytics.datasets import DATASET_DIR, DATASETS, dataset_path, make_dataset, open_dataset
from sim.params import PHYSICS_VERSION, SimParams


def _option(command, name):
    argv = shlex.split(command)
    return argv[argv.index(name) + 1] if name in argv else None


def _expected_name(sim_command):
    """A dataset's name from its simulation command: the preset (with -seedN for seeds > 0), or for
    a drum sized by confinement cg1-n<N> / cg1-dd<D/d>, -fr when Ω is the Froude-matched one, -seedN."""
    preset, seed = _option(sim_command, "--preset"), int(_option(sim_command, "--seed"))
    particles, ratio = _option(sim_command, "--drum-particles"), _option(sim_command, "--drum-ratio")
    if particles is None and ratio is None:
        return preset if seed == 0 else f"{preset}-seed{seed}"
    size = f"n{particles}" if particles is not None else f"dd{ratio}"
    return f"{preset.removeprefix('lab-')}-{size}{'-fr' if _option(sim_command, '--omega') else ''}-seed{seed}"


def test_the_registry_knows_todays_physics_version_and_says_which_runs_are_older(capsys):
    from granalytics.datasets import PHYSICS_RECHECKS, SIMULATOR_PHYSICS_VERSION, physics_note

    assert SIMULATOR_PHYSICS_VERSION == PHYSICS_VERSION
    assert physics_note("x", {"physics_version": PHYSICS_VERSION}) == f"physics version {PHYSICS_VERSION} (today's)"
    old = physics_note("lab-cg3-seed2", {"physics_version": PHYSICS_VERSION - 1})
    assert f"today's is {PHYSICS_VERSION}" in old
    assert old.endswith(PHYSICS_RECHECKS.get("lab-cg3", "not rechecked with today's simulator"))
    assert _main(["list"]) == 0
    listed = capsys.readouterr().out
    notes = [line.strip() for line in listed.splitlines() if line.strip().startswith("physics version")]
    assert len(notes) == len(DATASETS) + len(ga.datasets.SWEEPS)


@pytest.mark.parametrize("name", sorted(DATASETS))
def test_bundled_dataset_matches_registry_and_its_recipe(name):
    path = dataset_path(name)
    entry = DATASETS[name]
    sim_command, subset_command = entry["commands"]
    with open_dataset(name) as run:
        meta = run.meta
        assert meta.sim_config["params"]["alpha"] == meta.alpha
        seed = int(_option(sim_command, "--seed"))
        assert name == _expected_name(sim_command) and meta.provenance["code"] == "sim"
        assert meta.sim_config["params"]["seed"] == seed  # a replica is the preset at another seed
        revolutions = float(_option(sim_command, "--revolutions"))
        assert run.revolutions[-1] == pytest.approx(revolutions, abs=1e-3)  # the whole run, last frame included
        # the registry says which physics version made the file; an older one than today's is said by
        # `datasets list`, with the recheck of its statistics where one was made
        assert meta.provenance["physics_version"] == entry["physics_version"] <= PHYSICS_VERSION
        assert meta.provenance["wall_time_s"] > 0  # the simulator's wall time, for CG speed-ups
        kept = meta.provenance["subset_of"]["frames_kept"]
        assert len(run) == len(kept)
        window, every = _option(subset_command, "--full-window"), _option(subset_command, "--every")
        if window is None:  # every frame of the run, 0.05 revolution apart, or every N-th
            assert np.allclose(np.diff(run.revolutions), 0.05 * int(every or 1), atol=1e-3)
        else:  # every (--window-every-th) frame inside the window, every N-th before it
            lo, hi = map(float, window.split(":"))
            inside = run.revolutions >= lo - 0.005  # a tenth of a frame spacing: 2.99995 is in [3, 6]
            window_every = int(_option(subset_command, "--window-every") or 1)
            assert np.allclose(np.diff(run.revolutions[inside]), 0.05 * window_every, atol=1e-3)
            assert np.allclose(np.diff(run.revolutions[~inside]), 0.05 * int(every), atol=1e-3)
            assert run.revolutions[inside][0] == pytest.approx(lo, abs=1e-3)  # the window whole, from its start
        assert meta.provenance["threads"] == int(_option(sim_command, "--threads"))  # bit-identical per thread count
        assert run[len(run) // 2].n_contacts > 0
    assert path.relative_to(DATASET_DIR).as_posix() == entry["file"]


def test_bundled_data_stay_within_the_100_mb_budget():
    from granalytics.datasets import DATASET_DIR

    total = sum(p.stat().st_size for p in DATASET_DIR.rglob("*") if p.is_file())
    assert 50e6 < total <= 100e6, f"datasets/ holds {total} bytes"


def test_confinement_recipes_name_their_runs():
    from granalytics.datasets import CONFINEMENT

    assert len(CONFINEMENT) == 10
    for name, entry in CONFINEMENT.items():
        assert _expected_name(entry["commands"][0]) == name
        assert name not in DATASETS


def test_replica_sets_are_one_system_at_different_seeds():
    from granalytics.datasets import REPLICAS, replica_paths

    for name, members in REPLICAS.items():
        metas = []
        for path in replica_paths(name):
            with ga.open_run(path) as run:
                metas.append(run.meta)
        seeds = [m.sim_config["params"]["seed"] for m in metas]
        assert len(set(seeds)) == len(seeds) == len(members) and seeds[0] == 0
        # the same system otherwise (runs made before SimParams had contact_law used its default)
        default = {"contact_law": SimParams.__dataclass_fields__["contact_law"].default}
        params = [{**default, **{k: v for k, v in m.sim_config["params"].items() if k != "seed"}} for m in metas]
        assert all(p == params[0] for p in params)
    with pytest.raises(GranalyticsError, match="unknown replica set"):
        replica_paths("paper-cg3")


def test_unknown_or_corrupt_dataset_is_an_error(tmp_path, monkeypatch):
    with pytest.raises(GranalyticsError, match="unknown dataset"):
        dataset_path("nope")
    import granalytics.datasets.catalogue as ds

    monkeypatch.setitem(ds.DATASETS, "fake", {"file": "fake.h5", "sha256": "0" * 64, "commands": ["x"]})
    monkeypatch.setattr(ds, "DATASET_DIR", tmp_path)
    with pytest.raises(GranalyticsError, match="missing"):
        dataset_path("fake")
    (tmp_path / "fake.h5").write_bytes(b"x")
    with pytest.raises(GranalyticsError, match="does not match"):
        dataset_path("fake")


def test_make_datasets_runs_the_recipe_and_never_downloads(capsys):
    make_dataset("lab-cg3", dry_run=True)
    out = capsys.readouterr().out
    assert "-m sim run --preset lab-cg3" in out and "-m granalytics subset" in out
    assert "http" not in out and "curl" not in out and "wget" not in out
    assert _main(["make", "no-such-set"]) == 2


def test_bundle_sweep_copies_finished_points_as_float32_with_their_new_sums(tmp_path, capsys):
    import h5py
    import pandas as pd
    from test_study import write_point

    from granalytics.datasets import bundle_sweep, file_sha256 as _sha256

    src = tmp_path / "sweep"
    (src / "points").mkdir(parents=True)
    rows = []
    for k, gamma in enumerate((0.05, 0.2)):
        name = f"gamma={gamma:g}_omega=2"
        write_point(src / "points" / f"{name}.h5", gamma, 2.0, seed=k)
        rows.append({"point": name, "status": "done", "gamma": gamma, "omega": 2.0,
                     "file": f"points/{name}.h5", "sha256": _sha256(src / "points" / f"{name}.h5")})
    rows.append({"point": "gamma=0.3_omega=2", "status": "failed", "gamma": 0.3, "omega": 2.0,
                 "file": "points/gamma=0.3_omega=2.h5", "sha256": ""})
    pd.DataFrame(rows).to_csv(src / "manifest.csv", index=False)

    dst = bundle_sweep(src, tmp_path / "bundled", progress=False)
    assert "gamma=0.3_omega=2" in capsys.readouterr().err  # the unfinished point is named
    table = pd.read_csv(dst / "manifest.csv")
    assert list(table.point) == [r["point"] for r in rows[:2]]
    assert list(table.source_sha256) == [r["sha256"] for r in rows[:2]]
    for rel, digest in zip(table.file, table.sha256):
        assert _sha256(dst / rel) == digest
        with h5py.File(dst / rel, "r") as f, h5py.File(src / rel, "r") as g:
            assert f["particles/position"].dtype == np.float32
            assert f["particles/position"].shape == g["particles/position"].shape  # every frame
    with pytest.raises(GranalyticsError, match="exists"):
        bundle_sweep(src, dst, progress=False)
    assert _main(["bundle-sweep", str(src), str(dst)]) == 2
    # thinned: every frame in the window, every second one before it (as granalytics subset)
    rel = table.file[0]
    with ga.open_run(src / rel) as run:
        revs = run.revolutions
    window = (float(revs[-3]), float(revs[-1]))
    expected = [k for k in range(len(revs)) if k % 2 == 0 or window[0] <= revs[k] <= window[1]]
    assert len(expected) < len(revs)
    thin = tmp_path / "thin"
    assert _main(["bundle-sweep", str(src), str(thin), "--every", "2", "--full-window", f"{window[0]!r}:{window[1]!r}"]) == 0
    with ga.open_run(thin / rel) as run:
        assert run.meta.provenance["subset_of"]["frames_kept"] == expected
    with pytest.raises(SystemExit) as refused:  # argparse refuses the option value, exit status 2
        _main(["bundle-sweep", str(src), str(tmp_path / "bad"), "--every", "0"])
    assert refused.value.code == 2
    capsys.readouterr()
    assert _main(["bundle-sweep", str(src), str(tmp_path / "bad"), "--window-every", "2"]) == 2  # no window
    assert "window_every" in capsys.readouterr().err and not (tmp_path / "bad").exists()
    thinner = tmp_path / "thinner"
    assert _main(["bundle-sweep", str(src), str(thinner), "--every", "4", "--full-window",
                  f"{window[0]!r}:{window[1]!r}", "--window-every", "2"]) == 0
    with ga.open_run(thinner / rel) as run:
        assert run.meta.provenance["subset_of"]["frames_kept"] == [
            k for k in range(len(revs)) if k % 4 == 0 or (k % 2 == 0 and window[0] <= revs[k] <= window[1])]
    # the bundle is a normal folder (mkdtemp made it private), and a file as the target is one line
    import os
    import stat

    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(os.stat(dst).st_mode) == 0o777 & ~umask
    target = tmp_path / "a_file"
    target.write_text("x")
    capsys.readouterr()
    assert _main(["bundle-sweep", str(src), str(target), "--overwrite"]) == 2
    assert "exists and is not a folder" in capsys.readouterr().err and target.read_text() == "x"
    # one bundling at a time into a target (DST.lock beside it)
    from granalytics.base.errors import RunLockedError
    from granalytics.base.files import WriterLock

    with WriterLock(tmp_path / "busy"):
        with pytest.raises(RunLockedError, match="busy.lock"):
            bundle_sweep(src, tmp_path / "busy", progress=False)
    assert not (tmp_path / "busy").exists()


def test_thinned_frames_keeps_the_window_and_every_nth_frame():
    revs = np.arange(13) * 0.25
    assert list(ga.core.thinned_frames(revs)) == list(range(13))
    assert list(ga.core.thinned_frames(revs, 4)) == [0, 4, 8, 12]
    assert list(ga.core.thinned_frames(revs, 4, (1.5, 2.0))) == [0, 4, 6, 7, 8, 12]
    with pytest.raises(GranalyticsError, match="every"):
        ga.core.thinned_frames(revs, 0)
    with pytest.raises(GranalyticsError, match="full_window"):
        ga.core.thinned_frames(revs, 2, (2.0, 1.0))


def test_thinned_frames_thins_the_window_by_its_own_stride():
    revs = np.arange(25) * 0.125
    assert list(ga.core.thinned_frames(revs, 8, (2.0, 3.0), window_every=2)) == [0, 8, 16, 18, 20, 22, 24]
    assert list(ga.core.thinned_frames(revs, 8, (2.0, 3.0), window_every=4)) == [0, 8, 16, 20, 24]
    with pytest.raises(GranalyticsError, match="window_every"):
        ga.core.thinned_frames(revs, 2, None, window_every=2)
    with pytest.raises(GranalyticsError, match="window_every"):
        ga.core.thinned_frames(revs, 2, (1.0, 2.0), window_every=0)


def test_thinning_a_thinned_copy_keeps_the_frames_one_thinning_would():
    """A bundled sweep kept every 2nd raw frame; thinning that copy with every 4 outside the window
    keeps the frames that every 8 outside, every 2 inside would keep from the raw run."""
    raw = np.arange(121) * 0.05 * (1 - 1e-5)  # stamped just before the nominal times, as the simulator's are
    direct = ga.core.thinned_frames(raw, 8, (3.0, 6.0), window_every=2)
    copy = ga.core.thinned_frames(raw, 2)
    again = copy[ga.core.thinned_frames(raw[copy], 4, (3.0, 6.0))]
    assert list(again) == list(direct)
    assert len(direct) == 8 + 31 and raw[60] < 3.0 and 60 in direct  # the frame at 2.99997 is in [3, 6]


@pytest.mark.parametrize("name", sorted(__import__("granalytics.datasets", fromlist=["SWEEPS"]).SWEEPS))
def test_bundled_sweep_matches_registry_and_its_spec(name):
    import tomllib

    import pandas as pd

    from granalytics.datasets import DATASET_DIR, SWEEPS, sweep_path

    folder = sweep_path(name)
    entry = SWEEPS[name]
    spec = tomllib.loads((DATASET_DIR / entry["spec"]).read_text())
    table = pd.read_csv(folder / "manifest.csv")
    assert (table.status == "done").all() and (table.preset == spec["preset"]).all()
    expected = {(g, w) for g in spec["grid"]["gamma"] for w in spec["grid"]["omega"]}
    assert set(zip(table.gamma, table.omega)) == expected
    assert (table.revolutions == spec["revolutions"]).all()


def test_make_runs_recipes_side_by_side_and_reports_each_failure(monkeypatch, capsys):
    import granalytics.datasets as ds

    ran = []
    monkeypatch.setattr(ds, "make_dataset", lambda name, dry_run, progress=False: ran.append(name) or "")

    def failing_sweep(name, dry_run, progress=False):
        raise RuntimeError("recipe exited with status 1")

    monkeypatch.setattr(ds, "make_sweep", failing_sweep)
    names = sorted(DATASETS)
    assert _main(["make", "--jobs", "2", *names]) == 0
    assert sorted(ran) == names
    sweep = sorted(ds.SWEEPS)[0]
    assert _main(["make", "-j", "2", names[0], sweep]) == 1
    assert f"{sweep}: recipe exited with status 1" in capsys.readouterr().err
    # one recipe at a time too: a failure is one line and the others still run
    ran.clear()
    assert _main(["make", sweep, names[0]]) == 1
    assert ran == [names[0]] and f"{sweep}: recipe exited with status 1" in capsys.readouterr().err
    assert _main(["make", "--jobs", "0"]) == 2


def test_the_list_prints_the_confinement_runs_with_their_commands(capsys):
    from granalytics.cli.datasets import main
    from granalytics.datasets import CONFINEMENT

    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name, entry in CONFINEMENT.items():
        assert f"$ {entry['commands'][0]}" in out and name in out
