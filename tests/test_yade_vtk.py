"""YADE's VTKRecorder output read directly (``convert --from yade-vtk``), against what
``O.interactions`` held at the same instant (the CSV export written beside each VTK frame by
tests/data/yade_vtk/make_fixture.py, YADE 2023.02a)."""

import numpy as np
import pytest

import granalytics as ga
from granalytics.convert._text import DumpFormatError
from granalytics.convert.registry import read_run_files
from granalytics.convert.yade_vtk import find_vtk_frames

pytest.importorskip("vtk")
from pathlib import Path  # noqa: E402

DATA = Path(__file__).parent / "data" / "yade_vtk"
MAPPING = DATA / "mapping.toml"
DT = 3e-6


def truth(layout):
    folder = DATA / layout
    return read_run_files("yade", sorted(folder.glob("truth_particles_*.csv")),
                          sorted(folder.glob("truth_contacts_*.csv")), DATA / "truth.toml")[0]


@pytest.mark.parametrize("layout, frames", [("multiblock", [12000, 16000]), ("single", [12000])])
def test_the_recorders_frames_give_yades_own_particles_contacts_and_granules(layout, frames):
    read, meta = read_run_files("yade-vtk", [DATA / layout], [], MAPPING, DT)
    expected = truth(layout)
    assert [s.step for s in read] == frames == [s.step for s in expected]
    assert meta.capillary_in_contact is False and meta.provenance["source"] == "YADE VTKRecorder"
    for got, want in zip(read, expected):
        assert got.time == pytest.approx(want.step * DT)
        np.testing.assert_array_equal(got.ids, want.ids)
        np.testing.assert_array_equal(got.radius, want.radius)
        np.testing.assert_allclose(got.position, want.position, rtol=0, atol=2e-9)  # single precision
        np.testing.assert_allclose(got.velocity, want.velocity, rtol=1e-12, atol=0)
        got_pairs = list(zip(got.contact_i, got.contact_j))
        want_pairs = list(zip(want.contact_i, want.contact_j))
        assert sorted(got_pairs) == sorted(want_pairs)  # every sphere-sphere interaction, named by its ends
        order = np.lexsort((got.contact_j, got.contact_i))
        ref = np.lexsort((want.contact_j, want.contact_i))
        np.testing.assert_allclose(got.gap[order], want.gap[ref], rtol=0, atol=5e-9)
        assert np.array_equal(got.gap[order] > 0, want.gap[ref] > 0)
        np.testing.assert_allclose(got.f_normal[order], want.f_normal[ref], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(got.f_cap[order], want.f_cap[ref], rtol=1e-9, atol=1e-15)  # the rule on YADE's values
        assert (got.f_cap > 0).sum() > 50  # bridges, not only dry contacts
        for cohesion in ("acting", "bridge"):
            a = ga.identify(got, cohesion=cohesion).partition()
            b = ga.identify(want, cohesion=cohesion).partition()
            assert a == b and len(a) > 0


def test_convert_from_a_recorders_folder_then_info(tmp_path, capsys):
    from granalytics.cli import main

    out = tmp_path / "run.h5"
    assert main(["convert", str(DATA / "multiblock"), "--from", "yade-vtk", "--mapping", str(MAPPING),
                 "--dt-s", str(DT), "--out", str(out), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["info", str(out), "--json"]) == 0
    import json

    info = json.loads(capsys.readouterr().out)
    assert info["meta"]["provenance"]["source"] == "YADE VTKRecorder" and info["file"]["frames"] == 2
    with ga.open_run(out) as run:
        assert len(run) == 2 and run.n_particles == 246


def test_what_the_folder_lacks_is_named_with_the_recorder_to_add(tmp_path):
    import shutil

    single = tmp_path / "single"
    shutil.copytree(DATA / "single", single)
    (single / "drum-intrs.12000.vtp").unlink()
    with pytest.raises(DumpFormatError, match="add 'intr' to the VTKRecorder's recorders"):
        read_run_files("yade-vtk", [single], [], MAPPING, DT)
    with pytest.raises(DumpFormatError, match="no VTKRecorder frames"):
        find_vtk_frames([tmp_path / "nothing"])
    mixed = tmp_path / "mixed"
    shutil.copytree(DATA / "multiblock", mixed)
    shutil.copy(DATA / "single" / "drum-spheres.12000.vtu", mixed / "other-spheres.16000.vtu")
    with pytest.raises(DumpFormatError, match="recordings of 2 VTKRecorders are mixed"):
        find_vtk_frames([mixed])
    broken = tmp_path / "broken"
    shutil.copytree(DATA / "single", broken)
    (broken / "drum-spheres.12000.vtu").write_bytes(b"<?xml version='1.0'?><VTKFile type='Unstru")
    with pytest.raises(DumpFormatError, match=r"drum-spheres.12000.vtu: cannot read as VTK XML"):
        read_run_files("yade-vtk", [broken], [], MAPPING, DT)
    with pytest.raises(ga.GranalyticsError, match="time step"):
        read_run_files("yade-vtk", [DATA / "single"], [], MAPPING, None)


@pytest.mark.parametrize("prefix", ["", "drum_", "drum"])
def test_a_recorder_whose_file_name_does_not_end_in_a_dash_is_read(tmp_path, prefix):
    """VTKRecorder writes fileName + "spheres." + iter + ".vtu": fileName="out/" (YADE's examples)
    was refused ("no VTKRecorder frames")."""
    import shutil

    for path in (DATA / "single").iterdir():
        shutil.copy(path, tmp_path / path.name.replace("drum-", prefix))
    expected, _ = read_run_files("yade-vtk", [DATA / "single"], [], MAPPING, DT)
    snapshots, _ = read_run_files("yade-vtk", [tmp_path], [], MAPPING, DT)
    assert [s.step for s in snapshots] == [s.step for s in expected]
    np.testing.assert_array_equal(snapshots[-1].contact_i, expected[-1].contact_i)


def test_the_disk_check_of_a_folder_counts_the_files_in_it(tmp_path, monkeypatch):
    """the disk a conversion needs was estimated from os.path.getsize(folder), 4 kB."""
    import granalytics.base.resources as resources
    from granalytics.cli import main

    asked = []
    monkeypatch.setattr(resources, "check_disk", lambda what, size, path: asked.append(size))
    folder = DATA / "multiblock"
    assert main(["convert", str(folder), "--from", "yade-vtk", "--mapping", str(MAPPING), "--dt-s", str(DT),
                 "--out", str(tmp_path / "run.h5"), "--quiet"]) == 0
    files = sum(p.stat().st_size for p in folder.rglob("*.vt?"))
    assert files > 5e4 and asked == [int(0.6 * files)]
