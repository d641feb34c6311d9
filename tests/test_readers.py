"""One suite for every reader of other codes' files (granalytics.convert.registry.READERS): each one
converts its example files (real output of the code, tests/data/) into valid, ordered frames that
granalytics analyses, through the registry and through ``granalytics convert --from NAME``."""

from pathlib import Path

import numpy as np
import pytest

import granalytics as ga
from granalytics.cli import main
from granalytics.convert.registry import READERS, read_run_files

DATA = Path(__file__).parent / "data"
#: reader -> (particle files, contact files, mapping, dt_s [s]); every registered reader needs one
EXAMPLES = {
    "liggghts": (sorted((DATA / "liggghts_wet_drum").glob("atoms.*.dump.gz")),
                 sorted((DATA / "liggghts_wet_drum").glob("pairs.*.dump.gz")),
                 DATA / "liggghts_wet_drum" / "mapping.toml", 2e-6),
    "yade": (sorted((DATA / "yade_wet_drum").glob("frame_particles_*.csv.gz")),
             sorted((DATA / "yade_wet_drum").glob("frame_contacts_*.csv.gz")),
             DATA / "yade_wet_drum" / "meta.toml", None),
    "yade-vtk": (sorted((DATA / "yade_vtk" / "multiblock").glob("*.vtm")), [], DATA / "yade_vtk" / "mapping.toml", 3e-6),
}


def test_every_reader_has_an_example():
    assert set(EXAMPLES) == set(READERS)


@pytest.mark.parametrize("name", sorted(READERS))
def test_reader_gives_valid_ordered_frames_that_analyse(name):
    particles, contacts, mapping, dt_s = EXAMPLES[name]
    assert particles and (contacts or not READERS[name].needs_contacts)
    snapshots, meta = read_run_files(name, particles, contacts, mapping, dt_s)
    assert len(snapshots) >= 2
    times = [s.time for s in snapshots]
    assert times == sorted(times) and len(set(times)) == len(times)
    ids = snapshots[0].ids
    for s in snapshots:
        s.validate()  # fields, shapes, indices, finiteness
        assert s.meta == meta and s.n_particles == meta.n_particles
        assert set(s.ids) == set(ids)  # the same particles in every frame
    assert snapshots[-1].n_contacts > 0
    result = ga.identify(snapshots[-1], c_agg=0.3)
    assert result.labels.shape == (meta.n_particles,)
    assert ga.bed_structure(snapshots[-1]).n_particles == meta.n_particles


@pytest.mark.parametrize("name", sorted(READERS))
def test_convert_through_the_registry_writes_a_run_and_names_a_missing_file(name, tmp_path, capsys):
    particles, contacts, mapping, dt_s = EXAMPLES[name]
    out = tmp_path / "run.h5"
    dt = ["--dt-s", str(dt_s)] if READERS[name].needs_dt else []
    if contacts:
        dt += ["--contacts", *map(str, contacts)]
    assert main(["convert", *map(str, particles), "--from", name, "--mapping", str(mapping), *dt, "--out", str(out),
                 "--quiet"]) == 0
    with ga.open_run(out) as run:
        assert len(run) == len(read_run_files(name, particles, contacts, mapping, dt_s)[0])
        assert np.isfinite(run.times).all()
    capsys.readouterr()
    missing = tmp_path / "gone" / particles[0].name
    assert main(["convert", str(missing), "--from", name, "--mapping", str(mapping), *dt,
                 "--out", str(tmp_path / "b.h5"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert str(missing) in err and len(err.strip().splitlines()) == 1


def test_unknown_reader_is_refused():
    with pytest.raises(ga.ParameterError, match="unknown reader 'nope'"):
        read_run_files("nope", [], [], "x.toml")


@pytest.mark.parametrize("name", ["liggghts-wet-drum", "yade-wet-drum"])
def test_bundled_runs_of_other_codes_match_their_raw_output(name, tmp_path):
    """The converted LIGGGHTS and YADE runs in datasets/ are the conversion of their raw output
    (made by the real programs, kept in tests/data/): re-converted here without the programs.
    Positions are copied (exact); the YADE reader computes Willett's F_cap(0+) of touching wet
    pairs with exp/log, whose last bits differ between CPUs: f_cap is compared to rtol 1e-12
    (measured: 0 on the machine that bundled it; libm differences are a few ulp, ~1e-16)."""
    import shlex

    from granalytics.datasets import FOREIGN, foreign_path

    entry = FOREIGN[name]
    argv = shlex.split(entry["commands"][0])[1:]  # granalytics convert ...
    out = tmp_path / "again.h5"
    argv[argv.index("--out") + 1] = str(out)
    root = Path(__file__).resolve().parents[1]
    argv = [str(root / a) if a.startswith("tests/") else a for a in argv]
    assert main(argv) == 0
    with ga.open_run(foreign_path(name)) as bundled, ga.open_run(out) as again:
        assert len(bundled) == len(again) >= 2
        for a, b in zip(bundled, again):
            assert np.array_equal(a.position, b.position) and np.array_equal(a.contact_i, b.contact_i)
            np.testing.assert_allclose(b.f_cap, a.f_cap, rtol=1e-12, atol=0)
        result = ga.identify(bundled[len(bundled) - 1], c_agg=0.3)
        assert result.labels.shape == (bundled.n_particles,)
