"""YADE CSV export (scripts/yade_export.py) read end to end, and its errors."""

import gzip
from pathlib import Path

import numpy as np
import pytest

import granalytics as ga
from granalytics import GranalyticsError, ValidationError
from granalytics.cli import main
from granalytics.convert.yade import read_yade_csv

DATA = Path(__file__).parent / "data" / "yade_wet_drum"
PARTICLES = sorted(DATA.glob("frame_particles_*.csv.gz"))
CONTACTS = sorted(DATA.glob("frame_contacts_*.csv.gz"))


def test_yade_fixture_reads_and_analyses(tmp_path, capsys):
    snapshots, meta = read_yade_csv(PARTICLES, CONTACTS, DATA / "meta.toml")
    assert [s.step for s in snapshots] == [12000, 16000] and meta.n_particles == 246
    s = snapshots[-1]
    assert s.time == pytest.approx(16000 * 3e-6)
    # YADE applies capillary forces only to separated bridges: the force of the separated ones
    # is its attractive normal force
    active = (s.f_cap > 0) & (s.gap > 0)
    assert active.any() and (s.f_normal[active] < 0).all()
    np.testing.assert_array_equal(s.f_cap[active], -s.f_normal[active])
    np.testing.assert_allclose(s.bridge_volume, 1e-11)
    assert ga.identify(s, c_agg=0.3).n_granules > 0
    out = tmp_path / "y.h5"
    assert main(["convert", *map(str, PARTICLES), "--from", "yade", "--contacts", *map(str, CONTACTS),
                 "--mapping", str(DATA / "meta.toml"), "--out", str(out), "--quiet"]) == 0
    assert main(["stats", str(out), "--window", "0:1", "--quiet"]) == 0
    assert "yield_fraction" in capsys.readouterr().out


def test_malformed_yade_csv_names_file_and_line(tmp_path):
    text = gzip.open(CONTACTS[-1], "rt").read().splitlines()
    bad = tmp_path / "c.csv"
    bad.write_text("\n".join(text[:5] + ["999999," + text[5].split(",", 1)[1]] + text[6:]) + "\n")
    with pytest.raises(GranalyticsError, match=r"c.csv, line 6: particle id 999999"):
        read_yade_csv(PARTICLES[-1:], [bad], DATA / "meta.toml")
    text = gzip.open(PARTICLES[-1], "rt").read().splitlines()
    nan = tmp_path / "p.csv"
    nan.write_text("\n".join(text[:4] + [text[4].rsplit(",", 1)[0] + ",nan"] + text[5:]) + "\n")
    with pytest.raises(GranalyticsError, match=r"p.csv, line 5: non-finite or missing value in column 'film_volume'"):
        read_yade_csv([nan], CONTACTS[-1:], DATA / "meta.toml")
    meta = tmp_path / "m.toml"
    meta.write_text("surface_tension = 0.1\ndensity = 2500.0\ndrum_omega = 2.0\ngravityy = 1\n")
    with pytest.raises(GranalyticsError, match="unknown keys"):
        read_yade_csv(PARTICLES, CONTACTS, meta)


@pytest.mark.parametrize("gz", [False, True])
@pytest.mark.parametrize("which", ["particles", "contacts"])
def test_yade_csv_cut_inside_its_last_line_is_refused(tmp_path, gz, which):
    source = (PARTICLES if which == "particles" else CONTACTS)[-1]
    text = gzip.open(source, "rt").read()
    cut = text.rstrip("\n")[:-3]
    path = tmp_path / (source.name if gz else source.name[:-3])
    with (gzip.open(path, "wt") if gz else open(path, "w")) as f:
        f.write(cut)
    particles = [path] if which == "particles" else PARTICLES[-1:]
    contacts = [path] if which == "contacts" else CONTACTS[-1:]
    with pytest.raises(GranalyticsError) as err:
        read_yade_csv(particles, contacts, DATA / "meta.toml")
    msg = str(err.value)
    assert msg.startswith(f"{path}, line {cut.count(chr(10)) + 1}: ") and "cut short" in msg


def test_unused_contact_files_are_reported_and_a_bad_step_names_the_file(tmp_path):
    with pytest.warns(UserWarning, match=r"1 contact timestep\(s\) without a particle timestep are not converted \(12000"):
        snapshots, _ = read_yade_csv(PARTICLES[1:], CONTACTS, DATA / "meta.toml")
    assert [s.step for s in snapshots] == [16000]
    with pytest.raises(GranalyticsError, match="particle files end at timestep 12000 but the contact files go on to 16000"):
        read_yade_csv(PARTICLES[:1], CONTACTS, DATA / "meta.toml")
    text = gzip.open(PARTICLES[-1], "rt").read().splitlines()
    bad = tmp_path / "p.csv"
    bad.write_text("\n".join([text[0].replace("step=16000", "step=16k")] + text[1:]) + "\n")
    assert "step=16k" in bad.read_text()
    with pytest.raises(GranalyticsError, match=r"p.csv, line 1: .*step a whole number.*'16k'"):
        read_yade_csv([bad], CONTACTS[-1:], DATA / "meta.toml")


def test_touching_wet_pairs_carry_willetts_bridge_force_at_contact():
    """YADE exports no force for a touching wet pair; the reader fills in Willett's F_cap(0⁺),
    which must equal the simulator's own Willett_numeric (sim.capillary, from YADE's source) at
    s = 0 with YADE's pair radius 2·r_i·r_j/(r_i + r_j)."""
    from sim.capillary import CAPILLARY_MODELS, capillary_force_scalar

    snapshots, meta = read_yade_csv(PARTICLES, CONTACTS, DATA / "meta.toml")
    s = snapshots[-1]
    touching_wet = (s.gap <= 0) & (s.bridge_volume > 0)
    assert touching_wet.sum() > 100
    r_i, r_j = s.radius[s.contact_i], s.radius[s.contact_j]
    expected = [capillary_force_scalar(CAPILLARY_MODELS["willett_numeric"], 0.0, v, 2 * a * b / (a + b),
                                       meta.surface_tension, meta.contact_angle)
                for v, a, b in zip(s.bridge_volume[touching_wet], r_i[touching_wet], r_j[touching_wet])]
    np.testing.assert_allclose(s.f_cap[touching_wet], expected, rtol=1e-12)
    # the acting convention still gives touching pairs no cohesion (YADE applies none there), the
    # bridge convention counts them: more particles in granules
    import granalytics as ga

    acting, bridge = ga.identify(s, cohesion="acting"), ga.identify(s, cohesion="bridge")
    assert (bridge.labels >= 0).mean() > (acting.labels >= 0).mean() + 0.1
    assert meta.provenance["capillary_type"] == "Willett_numeric"


def test_an_unknown_capillary_type_is_refused(tmp_path):
    mapping = tmp_path / "meta.toml"
    mapping.write_text((DATA / "meta.toml").read_text() + 'capillary_type = "Rabinovich"\n')
    with pytest.raises(ValidationError, match="capillary_type 'Rabinovich' is not read"):
        read_yade_csv(PARTICLES, CONTACTS, mapping)


def test_a_fractional_particle_or_contact_id_is_refused_naming_the_line(tmp_path):
    """Round three and four, B8: an id 11.5 was read as 11 without a word (the LAMMPS reader refuses it)."""
    text = gzip.open(PARTICLES[-1], "rt").read().splitlines()
    bad = tmp_path / "p.csv"
    bad.write_text("\n".join(text[:4] + [text[4].split(",", 1)[0] + ".5," + text[4].split(",", 1)[1]] + text[5:])
                   + "\n")
    with pytest.raises(GranalyticsError, match=r"p.csv, line 5: particle id .*\.5 is not a whole number"):
        read_yade_csv([bad], CONTACTS[-1:], DATA / "meta.toml")
    text = gzip.open(CONTACTS[-1], "rt").read().splitlines()
    bad = tmp_path / "c.csv"
    bad.write_text("\n".join(text[:5] + [text[5].split(",", 1)[0] + ".5," + text[5].split(",", 1)[1]] + text[6:])
                   + "\n")
    with pytest.raises(GranalyticsError, match=r"c.csv, line 6: id1 .*\.5 is not a whole number"):
        read_yade_csv(PARTICLES[-1:], [bad], DATA / "meta.toml")


def test_the_csv_export_is_read_one_frame_at_a_time(monkeypatch):
    """read_yade_csv read every file before it gave the first frame (and the memory check was
    told 0 bytes): a production run did not fit in memory."""
    import granalytics.convert.yade as yade

    parsed = []
    real = yade._read
    monkeypatch.setattr(yade, "_read", lambda path, columns: parsed.append(path) or real(path, columns))
    run = yade.open_yade_csv(PARTICLES[::-1], CONTACTS, DATA / "meta.toml")  # ordered by their steps
    assert parsed == [] and run.bytes_read == 0 and run.frame_bytes() > 8 * PARTICLES[0].stat().st_size
    first = run.first()
    assert first.step == 12000 and len(parsed) == 2 and run.meta.n_particles == 246
    assert 0 < run.bytes_read < run.total_bytes
    assert [s.step for s in run] == [12000, 16000] and run.bytes_read == run.total_bytes
    later = yade.open_yade_csv(PARTICLES, CONTACTS, DATA / "meta.toml")
    later.start_after(12000)
    assert [s.step for s in later] == [16000]
    none = yade.open_yade_csv(PARTICLES, CONTACTS, DATA / "meta.toml")
    none.start_after(16000)
    with pytest.raises(GranalyticsError, match="no frames after step 16000 in"):
        none.first()
