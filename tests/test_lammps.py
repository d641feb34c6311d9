"""LIGGGHTS / LAMMPS dump reader: round trip, clear errors, fuzzing."""

import gzip
import re
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import granalytics as ga
from granalytics import GranalyticsError
from granalytics.convert.lammps import DumpFormatError, DumpMapping, read_liggghts
from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot

ATOM_COLUMNS = ["x", "id", "vz", "radius", "type", "y", "omegax", "vx", "z", "omegaz", "vy", "omegay", "f_film"]
LOCAL_COLUMNS = ["c_pl[1]", "c_pl[2]", "c_pl[3]", "c_pl[4]", "c_pl[5]", "c_pl[6]"]
MAPPING = dict(surface_tension=0.1095, density=2500.0, drum_omega=2.0, contact_id_i="c_pl[2]", contact_id_j="c_pl[1]",
               contact_f_cap="c_pl[4]", contact_f_normal="c_pl[3]", contact_overlap="c_pl[6]",
               contact_bridge_volume="c_pl[5]", film_column="f_film")
DT = 1e-5


def atoms_block(s, step, order):
    values = {"id": s.ids + 100, "radius": s.radius, "type": np.ones(s.n_particles), "f_film": s.film_volume,
              **{c: s.position[:, k] for k, c in enumerate("xyz")},
              **{c: s.velocity[:, k] for k, c in enumerate(("vx", "vy", "vz"))},
              **{c: s.angular_velocity[:, k] for k, c in enumerate(("omegax", "omegay", "omegaz"))}}
    lines = ["ITEM: TIMESTEP", str(step), "ITEM: NUMBER OF ATOMS", str(s.n_particles),
             "ITEM: BOX BOUNDS ff ff ff", "-1 1", "-1 1", "-1 1", "ITEM: ATOMS " + " ".join(ATOM_COLUMNS)]
    table = np.column_stack([values[c] for c in ATOM_COLUMNS])[order]
    lines += [" ".join(repr(float(x)) for x in row) for row in table]
    return lines


def local_block(s, step):
    ids = s.ids + 100
    table = np.column_stack([ids[s.contact_j], ids[s.contact_i], s.f_normal, -s.f_cap, s.bridge_volume, -s.gap])
    lines = ["ITEM: TIMESTEP", str(step), "ITEM: NUMBER OF ENTRIES", str(s.n_contacts),
             "ITEM: BOX BOUNDS ff ff ff", "-1 1", "-1 1", "-1 1", "ITEM: ENTRIES " + " ".join(LOCAL_COLUMNS)]
    lines += [" ".join(repr(float(x)) for x in row) for row in table]
    return lines


@pytest.fixture(scope="module")
def frames():
    meta = synthetic_meta(300)
    return [synthetic_snapshot(300, time=k * 100 * DT, step=k * 100, seed=k, meta=meta) for k in range(3)]


def write_dumps(tmp_path, frames, gz=False, per_step=False, seed=0):
    rng = np.random.default_rng(seed)
    atoms = [atoms_block(s, s.step, rng.permutation(s.n_particles)) for s in frames]
    local = [local_block(s, s.step) for s in frames]
    opener = gzip.open if gz else open
    ext = ".gz" if gz else ""
    if per_step:
        pf, cf = [], []
        for s, a, l in zip(frames, atoms, local):
            pf.append(tmp_path / f"atoms.{s.step}{ext}")
            cf.append(tmp_path / f"pairs.{s.step}{ext}")
            with opener(pf[-1], "wt") as f:
                f.write("\n".join(a) + "\n")
            with opener(cf[-1], "wt") as f:
                f.write("\n".join(l) + "\n")
        return pf, cf
    pf, cf = tmp_path / f"atoms.dump{ext}", tmp_path / f"pairs.dump{ext}"
    with opener(pf, "wt") as f:
        f.write("\n".join(line for block in atoms for line in block) + "\n")
    with opener(cf, "wt") as f:
        f.write("\n".join(line for block in local for line in block) + "\n")
    return [pf], [cf]


def assert_same_run(read, frames):
    assert len(read) == len(frames)
    for r, s in zip(read, frames):
        order = np.argsort(r.ids)
        back = r.take_particles(order)
        np.testing.assert_array_equal(back.ids, s.ids + 100)
        for name in ("radius", "position", "velocity", "angular_velocity", "film_volume"):
            np.testing.assert_array_equal(getattr(back, name), getattr(s, name))
        assert r.time == pytest.approx(s.time) and r.step == s.step
        a = ga.identify(r)
        b = ga.identify(s)
        assert {frozenset(int(x) - 100 for x in g) for g in a.partition()} == b.partition()


@pytest.mark.parametrize("gz, per_step", [(False, False), (True, False), (False, True), (True, True)])
def test_round_trip_through_dump_files(tmp_path, frames, gz, per_step):
    pf, cf = write_dumps(tmp_path, frames, gz, per_step)
    snapshots, meta = read_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT)
    assert meta.n_particles == 300 and meta.surface_tension == 0.1095
    assert_same_run(snapshots, frames)


def test_what_the_dumps_cannot_say_must_be_declared(tmp_path, frames):
    pf, cf = write_dumps(tmp_path, frames)
    with pytest.raises(GranalyticsError, match="dt"):
        read_liggghts(pf, cf, DumpMapping(**MAPPING))
    with pytest.raises(GranalyticsError, match="units si"):
        DumpMapping(**MAPPING, units="lj")
    with pytest.raises(GranalyticsError, match="exactly one of contact_gap or contact_overlap"):
        DumpMapping(**{**MAPPING, "contact_overlap": None})
    with pytest.raises(DumpFormatError, match=r"pairs.dump, line \d+: no column 'c_pl\[9\]'"):
        read_liggghts(pf, cf, DumpMapping(**{**MAPPING, "contact_f_cap": "c_pl[9]"}), dt=DT)


def corrupt(path, fn):
    lines = open(path).read().splitlines()
    open(path, "w").write("\n".join(fn(lines)) + "\n")


@pytest.mark.parametrize("target, fn, words", [
    ("atoms", lambda ls: ls[:20], "file ends after"),
    ("atoms", lambda ls: ls[:12] + [ls[12].replace(ls[12].split()[3], "nan", 1)] + ls[13:], "non-finite"),
    ("atoms", lambda ls: ls[:12] + [" ".join(ls[12].split()[:-1])] + ls[13:], "values for"),
    ("atoms", lambda ls: ls + ls[: 9 + 300], "appears twice"),
    ("atoms", lambda ls: [l.replace(" omegay", " wy") for l in ls], "no column 'omegay'"),
    ("pairs", lambda ls: ls[:9] + ["999999 100 0 0 0 0"] + ls[10:], "not in the particle dump"),
    ("pairs", lambda ls: ls[:9] + [ls[9], ls[9]] + ls[11:], "duplicate contact pair"),
])
def test_malformed_dumps_give_clear_errors(tmp_path, frames, target, fn, words):
    pf, cf = write_dumps(tmp_path, frames)
    corrupt(pf[0] if target == "atoms" else cf[0], fn)
    with pytest.raises(GranalyticsError, match=words) as err:
        read_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT)
    assert "dump" in str(err.value)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(target=st.sampled_from(["atoms", "pairs"]), line=st.integers(0, 2000),
       action=st.sampled_from(["truncate", "drop_token", "nan", "garbage", "drop_line", "duplicate_line", "blank",
                               "rename_column", "unknown_id", "duplicate_block"]))
def test_fuzzed_dumps_give_an_error_or_the_right_run(tmp_path_factory, frames, target, line, action):
    tmp = tmp_path_factory.mktemp("fuzz")
    pf, cf = write_dumps(tmp, frames)
    if action == "unknown_id":  # contacts naming a particle id that is not in the particle dump
        target = "pairs"
    path = pf[0] if target == "atoms" else cf[0]
    lines = open(path).read().splitlines()
    k = line % len(lines)
    if action == "truncate":
        lines = lines[:k]
    elif action == "drop_token":
        lines[k] = " ".join(lines[k].split()[:-1])
    elif action == "nan":
        tokens = lines[k].split()
        tokens[-1] = "nan"
        lines[k] = " ".join(tokens)
    elif action == "garbage":
        lines[k] = lines[k] + " x"
    elif action == "drop_line":
        del lines[k]
    elif action == "duplicate_line":
        lines.insert(k, lines[k])
    elif action == "blank":
        lines.insert(k, "")
    elif action == "rename_column":  # a column the reader needs goes missing
        header = next(i for i, l in enumerate(lines) if l.startswith("ITEM: ATOMS") or l.startswith("ITEM: ENTRIES"))
        tokens = lines[header].split()
        tokens[2 + line % (len(tokens) - 2)] = "renamed"
        lines[header] = " ".join(tokens)
    elif action == "unknown_id":  # a row names a particle id that does not exist
        rows = [i for i, l in enumerate(lines) if l and l[0] in "-0123456789" and len(l.split()) > 3]
        r = rows[line % len(rows)]
        tokens = lines[r].split()
        tokens[0] = "987654321"
        lines[r] = " ".join(tokens)
    elif action == "duplicate_block":  # a timestep appears twice
        starts = [i for i, l in enumerate(lines) if l == "ITEM: TIMESTEP"] + [len(lines)]
        b = line % (len(starts) - 1)
        lines += lines[starts[b]:starts[b + 1]]
    open(path, "w").write("\n".join(lines) + "\n")
    try:
        snapshots, _ = read_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT)
    except GranalyticsError as exc:
        assert str(path.name) in str(exc) or "dump" in str(exc)
        return
    assert_same_run(snapshots, frames)  # only a harmless edit may pass, and then the run is right


def test_convert_cli_writes_a_run_that_stats_reads(tmp_path, frames, capsys):
    from granalytics.cli import main

    pf, cf = write_dumps(tmp_path, frames, gz=True)
    toml = tmp_path / "map.toml"
    toml.write_text("\n".join(f'{k} = {v!r}' if isinstance(v, str) else f"{k} = {v}" for k, v in MAPPING.items()).replace("'", '"'))
    out = tmp_path / "run.h5"
    assert main(["convert", *map(str, pf), "--contacts", *map(str, cf), "--mapping", str(toml), "--dt-s", str(DT),
                 "--out", str(out), "--quiet"]) == 0
    with ga.open_run(out) as run:
        assert_same_run(list(run), frames)
    assert main(["stats", str(out), "--window", "0:1", "--quiet"]) == 0
    bad = tmp_path / "bad.toml"
    bad.write_text(toml.read_text() + '\nsurface_tensionn = 1.0\n')
    assert main(["convert", *map(str, pf), "--contacts", *map(str, cf), "--mapping", str(bad), "--dt-s", "1e-5",
                 "--out", str(tmp_path / "x.h5"), "--quiet"]) == 2
    assert "unknown keys" in capsys.readouterr().err


def test_real_liggghts_wet_drum_fixture_end_to_end(tmp_path, capsys):
    """Dumps made by LIGGGHTS 3.8 (tests/data/liggghts_wet_drum/README.md), converted and analysed."""
    from pathlib import Path

    from granalytics.cli import main

    data = Path(__file__).parent / "data" / "liggghts_wet_drum"
    atoms = sorted(data.glob("atoms.*.dump.gz"), key=lambda p: int(p.name.split(".")[1]))
    pairs = sorted(data.glob("pairs.*.dump.gz"), key=lambda p: int(p.name.split(".")[1]))
    mapping = DumpMapping.from_toml(data / "mapping.toml")
    snapshots, meta = read_liggghts(atoms, pairs, mapping, dt=2e-6)
    assert [s.step for s in snapshots] == [5000, 10000, 15000, 20000] and meta.n_particles == 300
    last = snapshots[-1]
    assert last.n_contacts == 328  # the entries of pairs.20000
    assert (last.radius == 0.00075).all()
    # 1 % of the particle volume of liquid per particle at the start, conserved by LIGGGHTS' transfer
    v_p = 4 / 3 * np.pi * 0.00075**3
    assert snapshots[0].film_volume == pytest.approx(np.full(300, 0.01 * v_p))
    assert (last.f_cap > 0).any() and ((last.gap > 0) & (last.f_cap > 0)).any()  # separated bridges pull
    assert ga.identify(last, c_agg=0.3).n_granules > 0
    out = tmp_path / "lig.h5"
    argv = ["convert", *map(str, atoms), "--contacts", *map(str, pairs), "--mapping", str(data / "mapping.toml"),
            "--dt-s", "2e-6", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    assert main(["stats", str(out), "--window", "0:1", "--quiet"]) == 0
    assert "yield_fraction" in capsys.readouterr().out


@pytest.mark.parametrize("gz", [False, True])
@pytest.mark.parametrize("target", ["atoms", "pairs"])
def test_dump_cut_inside_its_last_number_is_refused(tmp_path, frames, gz, target):
    pf, cf = write_dumps(tmp_path, frames, gz=gz)
    path = pf[0] if target == "atoms" else cf[0]
    opener = gzip.open if gz else open
    with opener(path, "rt") as f:
        text = f.read()
    last = text.rstrip("\n").rsplit("\n", 1)[1]
    assert last.split()[-1].count(".") == 1
    cut = text.rstrip("\n")[:-3]  # the writer died inside the last number of the last line
    with opener(path, "wt") as f:
        f.write(cut)
    n_lines = cut.count("\n") + 1
    with pytest.raises(DumpFormatError) as err:
        read_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT)
    msg = str(err.value)
    assert msg.startswith(f"{path}, line {n_lines}: ") and "cut short" in msg and "\n" not in msg


def test_convert_cli_refuses_a_cut_dump_with_exit_2(tmp_path, frames, capsys):
    from granalytics.cli import main

    pf, cf = write_dumps(tmp_path, frames)
    text = pf[0].read_text()
    pf[0].write_text(text[:-5])
    toml = tmp_path / "map.toml"
    toml.write_text("\n".join(f'{k} = "{v}"' if isinstance(v, str) else f"{k} = {v}" for k, v in MAPPING.items()))
    out = tmp_path / "run.h5"
    assert main(["convert", str(pf[0]), "--contacts", str(cf[0]), "--mapping", str(toml), "--dt-s", str(DT),
                 "--out", str(out), "--quiet"]) == 2
    assert "cut short" in capsys.readouterr().err and not out.exists()


def test_binary_mapping_file_gives_one_line_naming_it(tmp_path, frames, capsys):
    from granalytics.cli import main
    from granalytics.convert.lammps import load_toml

    binary = tmp_path / "map.toml"
    binary.write_bytes(b'units = "si"\n' + bytes(range(128, 256)) + b"\x00\x01")
    with pytest.raises(GranalyticsError) as err:
        load_toml(binary)
    msg = str(err.value)
    assert msg.startswith(f"{binary}: ") and "UTF-8" in msg and "\n" not in msg
    with pytest.raises(GranalyticsError, match="UTF-8"):
        DumpMapping.from_toml(binary)
    pf, cf = write_dumps(tmp_path, frames)
    assert main(["convert", str(pf[0]), "--contacts", str(cf[0]), "--mapping", str(binary), "--dt-s", str(DT),
                 "--out", str(tmp_path / "run.h5"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(binary) in err


def test_dump_with_zero_atoms_is_refused_naming_the_file(tmp_path, frames):
    pf, cf = write_dumps(tmp_path, frames[:1])
    lines = pf[0].read_text().splitlines()
    pf[0].write_text("\n".join(lines[:3] + ["0"] + lines[4:9]) + "\n")
    local = cf[0].read_text().splitlines()
    cf[0].write_text("\n".join(local[:3] + ["0"] + local[4:9]) + "\n")
    with pytest.raises(GranalyticsError, match="no particles") as err:
        read_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT)
    assert str(pf[0]) in str(err.value)


def _mapping_file(tmp_path):
    toml = tmp_path / "map.toml"
    toml.write_text("\n".join(f'{k} = {v!r}' if isinstance(v, str) else f"{k} = {v}" for k, v in MAPPING.items()).replace("'", '"'))
    return toml


def test_a_failing_convert_leaves_the_existing_output_as_it_was(tmp_path, frames, capsys, monkeypatch):
    import hashlib

    from granalytics.cli import main
    from granalytics.core import RunWriter

    pf, cf = write_dumps(tmp_path, frames, per_step=True)
    out = tmp_path / "run.h5"
    argv = ["convert", *map(str, pf), "--contacts", *map(str, cf), "--mapping", str(_mapping_file(tmp_path)),
            "--dt-s", str(DT), "--out", str(out), "--quiet"]
    assert main(argv) == 0
    before = hashlib.sha256(out.read_bytes()).hexdigest()
    append, calls = RunWriter.append, []

    def disk_full_at_the_third_frame(self, snapshot):
        calls.append(snapshot.step)
        if len(calls) == 3:
            raise OSError("No space left on device")
        append(self, snapshot)

    monkeypatch.setattr(RunWriter, "append", disk_full_at_the_third_frame)
    assert main(argv + ["--overwrite"]) == 2
    assert "No space left" in capsys.readouterr().err
    assert hashlib.sha256(out.read_bytes()).hexdigest() == before
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith("run.h5")) == ["run.h5"]


def test_a_timestep_with_another_particle_count_is_refused_naming_its_dump(tmp_path, frames):
    fewer = synthetic_snapshot(299, time=200 * DT, step=200, seed=2, meta=frames[0].meta)
    pf, cf = write_dumps(tmp_path, [*frames[:2], fewer], per_step=True)
    with pytest.raises(DumpFormatError, match=rf"{pf[-1]}, line \d+: timestep 200 has 299 particles, the first timestep 300"):
        read_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT)


def test_contact_timesteps_without_particles_are_reported(tmp_path, frames, capsys):
    """Contacts dumped between the particle timesteps are left out with a warning; contacts after
    the last particle timestep mean that the particle dump ends early (cut at a timestep boundary,
    or a file left out): refused, naming the timesteps."""
    from granalytics.cli import main

    pf, cf = write_dumps(tmp_path, frames, per_step=True)
    common = ["--contacts", *map(str, cf), "--mapping", str(_mapping_file(tmp_path)), "--dt-s", str(DT), "--quiet"]
    assert main(["convert", str(pf[0]), str(pf[2]), *common, "--out", str(tmp_path / "run.h5")]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"granalytics: warning: 1 contact timestep(s) without a particle timestep are not converted "
                   f"(100; from {cf[0]}, {cf[1]}, {cf[2]})"]
    assert main(["convert", *map(str, pf[:2]), *common, "--out", str(tmp_path / "cut.h5")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "the particle files end at timestep 100 but the contact files go on to 200" in err[0]
    assert not (tmp_path / "cut.h5").exists()


def test_a_dump_cut_at_a_timestep_boundary_is_refused(tmp_path, frames):
    """The case hypothesis found (a particle dump cut exactly before a TIMESTEP line), kept as an example."""
    pf, cf = write_dumps(tmp_path, frames)
    lines = open(pf[0]).read().splitlines()
    last_block = max(i for i, line in enumerate(lines) if line == "ITEM: TIMESTEP")
    open(pf[0], "w").write("\n".join(lines[:last_block]) + "\n")
    with pytest.raises(DumpFormatError, match="particle files end at timestep 100 but the contact files go on to 200"):
        read_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT)


@pytest.mark.parametrize("line, words", [
    ("drum_omega = [1, 2]", "drum_omega"),
    ('drum_omega = "fast"', "drum_omega"),
    ('contact_angle = "20deg"', "contact_angle"),
    ('contact_f_normal = ["c_f[1]", "c_f[2]"]', "contact_f_normal"),
])
def test_a_mapping_value_of_the_wrong_kind_names_the_file_and_the_key(tmp_path, line, words):
    key = line.split(" = ")[0]
    body = [f'{k} = {v!r}'.replace("'", '"') if isinstance(v, str) else f"{k} = {v}" for k, v in MAPPING.items()
            if k != key]
    toml = tmp_path / "map.toml"
    toml.write_text("\n".join(body + [line]) + "\n")
    with pytest.raises(ga.ValidationError) as err:
        DumpMapping.from_toml(toml)
    assert words in str(err.value) and str(toml) in str(err.value)


# ---------------------------------------------------------------- ids read exactly (issue 33, A5)
def _with_ids(lines, column, write):
    """The dump ``lines`` with the values of ``column`` of every data row rewritten by ``write(value)``."""
    out, columns = [], None
    for line in lines:
        if line.startswith("ITEM: ATOMS") or line.startswith("ITEM: ENTRIES"):
            columns = line.split()[2:]
        elif line.startswith("ITEM:"):
            columns = None
        elif columns and len(line.split()) == len(columns):
            fields = line.split()
            k = columns.index(column)
            fields[k] = write(float(fields[k]))
            line = " ".join(fields)
        out.append(line)
    return out


def test_particle_ids_beyond_2_53_are_read_exactly_not_through_a_float(tmp_path, frames):
    """ids were read as float64: 9007199254740993 came back as ...992 (two particles one id)."""
    base = 9007199254740993 - 100  # atoms_block adds 100: ids from 2**53 + 1 upwards
    atoms = _with_ids(atoms_block(frames[0], 0, np.arange(300)), "id", lambda v: str(int(v) + base))
    local = _with_ids(_with_ids(local_block(frames[0], 0), "c_pl[1]", lambda v: str(int(v) + base)),
                      "c_pl[2]", lambda v: str(int(v) + base))
    (tmp_path / "a.dump").write_text("\n".join(atoms) + "\n")
    (tmp_path / "p.dump").write_text("\n".join(local) + "\n")
    snapshots, _ = read_liggghts([tmp_path / "a.dump"], [tmp_path / "p.dump"], DumpMapping(**MAPPING), dt=DT)
    np.testing.assert_array_equal(snapshots[0].ids, frames[0].ids + 100 + base)
    assert 9007199254740993 in snapshots[0].ids.tolist()
    assert ga.identify(snapshots[0]).partition() == {frozenset(int(x) + 100 + base for x in g)
                                                       for g in ga.identify(frames[0]).partition()}


@pytest.mark.parametrize("column, value, words", [
    ("c_pl[1]", "3.5", "is not a whole number"), ("id", "2.5", "is not a whole number"),
    ("id", "1e16", "float above 2**53"), ("c_pl[2]", "99999999999999999999", "beyond the 64-bit integers"),
])
def test_ids_that_are_not_exact_integers_are_refused_naming_the_line(tmp_path, frames, column, value, words):
    """a contact id 3.5 was truncated to particle 3; 1e16 rounded to another particle."""
    atoms, local = atoms_block(frames[0], 0, np.arange(300)), local_block(frames[0], 0)
    target = atoms if column == "id" else local
    header = next(k for k, line in enumerate(target) if line.startswith("ITEM: ATOMS") or line.startswith("ITEM: ENTRIES"))
    fields = target[header + 1].split()
    fields[target[header].split()[2:].index(column)] = value
    target[header + 1] = " ".join(fields)
    (tmp_path / "a.dump").write_text("\n".join(atoms) + "\n")
    (tmp_path / "p.dump").write_text("\n".join(local) + "\n")
    with pytest.raises(DumpFormatError, match=f"line {header + 2}: .*{value!r}") as exc:
        read_liggghts([tmp_path / "a.dump"], [tmp_path / "p.dump"], DumpMapping(**MAPPING), dt=DT)
    assert words in str(exc.value) and "\n" not in str(exc.value)


def test_tab_separated_dumps_read_as_the_space_separated_ones(tmp_path, frames):
    """'ITEM:\\tTIMESTEP' was refused ('expected ITEM: TIMESTEP'), though LAMMPS reads such a dump."""
    pf, cf = write_dumps(tmp_path, frames)
    spaced = read_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT)[0]
    for path in (*pf, *cf):
        path.write_text(path.read_text().replace(" ", "\t"))
    tabbed = read_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT)[0]
    assert len(tabbed) == len(spaced) == len(frames)
    for a, b in zip(spaced, tabbed):
        assert a.step == b.step
        for name in ("ids", "position", "contact_i", "contact_j", "f_cap"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_convert_without_dt_names_the_option(tmp_path, frames, capsys):
    from granalytics.cli import main

    pf, cf = write_dumps(tmp_path, frames)
    mapping = tmp_path / "map.toml"
    mapping.write_text("\n".join(f"{k} = {v!r}".replace("'", '"') for k, v in MAPPING.items()) + "\n")
    assert main(["convert", *map(str, pf), "--contacts", *map(str, cf), "--mapping", str(mapping),
                 "--out", str(tmp_path / "run.h5"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("granalytics: error: --dt-s:") and "\n" not in err


# ----------------------------------------------------------------------------- streaming, --append, interrupts
def test_frames_are_read_one_at_a_time_from_a_file_of_many_timesteps(tmp_path, frames, monkeypatch):
    from granalytics.convert.lammps import _BlockReader, open_liggghts

    monkeypatch.setattr(_BlockReader, "CHUNK", 4096)  # chunks smaller than a block, as for a production run

    pf, cf = write_dumps(tmp_path, frames)  # one file of three timesteps each
    run = open_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT)
    assert run.bytes_read == 0 and run.total_bytes == pf[0].stat().st_size + cf[0].stat().st_size
    assert run.first().step == 0 and run.meta.n_particles == 300
    assert 0 < run.bytes_read < run.total_bytes / 2  # the first of three blocks of each file, not more
    assert run.frame_bytes() > 0
    assert_same_run(list(run), frames)
    assert run.bytes_read == run.total_bytes


def test_files_are_taken_in_the_order_of_their_timesteps_and_a_step_back_is_refused(tmp_path, frames):
    pf, cf = write_dumps(tmp_path, frames, per_step=True)
    snapshots, _ = read_liggghts(pf[::-1], cf[1:] + cf[:1], DumpMapping(**MAPPING), dt=DT)
    assert_same_run(snapshots, frames)
    (tmp_path / "back").mkdir()
    back = write_dumps(tmp_path / "back", [frames[1], frames[0]])  # one file each, the second block earlier
    with pytest.raises(DumpFormatError, match=r"pairs.dump, line 760: timestep 0 comes after timestep 100"):
        read_liggghts(*back, DumpMapping(**MAPPING), dt=DT)


def _convert(pf, cf, tmp_path, *extra):
    from granalytics.cli import main

    return main(["convert", *map(str, pf), "--contacts", *map(str, cf), "--mapping", str(_mapping_file(tmp_path)),
                 "--dt-s", str(DT), "--out", str(tmp_path / "run.h5"), "--quiet", *extra])


def test_append_adds_the_later_frames_and_equals_one_conversion(tmp_path, frames, capsys):
    pf, cf = write_dumps(tmp_path, frames, per_step=True)
    assert _convert(pf[:2], cf[:2], tmp_path) == 0
    assert _convert(pf, cf, tmp_path, "--append") == 0
    assert "appended 1 frames to" in capsys.readouterr().out
    with ga.open_run(tmp_path / "run.h5") as run:
        assert_same_run(list(run), frames) and run.unfinished is None
        assert run.meta.provenance["appended_files"][0] == str(pf[0])
    assert _convert(pf, cf, tmp_path, "--append") == 2  # nothing after the last timestep
    assert "no particle timesteps after timestep 200" in capsys.readouterr().err
    other = tmp_path / "other.toml"
    other.write_text(_mapping_file(tmp_path).read_text().replace("density = 2500.0", "density = 1000.0"))
    from granalytics.cli import main

    assert main(["convert", *map(str, pf), "--contacts", *map(str, cf), "--mapping", str(other), "--dt-s", str(DT),
                 "--out", str(tmp_path / "run.h5"), "--quiet", "--append", "--overwrite"]) == 2
    assert "give one of them" in capsys.readouterr().err
    (tmp_path / "run.h5").unlink()
    assert _convert(pf[:1], cf[:1], tmp_path) == 0
    assert main(["convert", *map(str, pf), "--contacts", *map(str, cf), "--mapping", str(other), "--dt-s", str(DT),
                 "--out", str(tmp_path / "run.h5"), "--quiet", "--append"]) == 2
    err = capsys.readouterr().err
    assert "has density = 2500.0, the files give 1000.0" in err and "\n" not in err.strip()


def test_an_interrupted_conversion_keeps_its_frames_and_append_finishes_it(tmp_path, frames, capsys, monkeypatch):
    from granalytics.core import RunWriter

    pf, cf = write_dumps(tmp_path, frames, per_step=True)
    append = RunWriter.append

    def ctrl_c_at_the_third_frame(self, snapshot):
        if self.n_frames == 2:
            raise KeyboardInterrupt
        append(self, snapshot)

    monkeypatch.setattr(RunWriter, "append", ctrl_c_at_the_third_frame)
    assert _convert(pf, cf, tmp_path) == 130
    assert "holds the first 2 frames" in capsys.readouterr().err
    with ga.open_run(tmp_path / "run.h5") as run:
        assert len(run) == 2 and "stopped after 2 frames" in run.unfinished
    monkeypatch.setattr(RunWriter, "append", append)
    assert _convert(pf, cf, tmp_path, "--append") == 0
    with ga.open_run(tmp_path / "run.h5") as run:
        assert run.unfinished is None
        assert_same_run(list(run), frames)


def test_convert_shows_the_bytes_read_while_it_reads(tmp_path, frames, capsys):
    from granalytics.cli import main

    pf, cf = write_dumps(tmp_path, frames, gz=True)
    assert main(["convert", str(pf[0]), "--contacts", str(cf[0]), "--mapping", str(_mapping_file(tmp_path)),
                 "--dt-s", str(DT), "--out", str(tmp_path / "run.h5")]) == 0
    err = capsys.readouterr().err
    total = pf[0].stat().st_size + cf[0].stat().st_size
    assert "convert: 100%" in err and "3 frames" in err and f"{total / 1e3:.0f}k/{total / 1e3:.0f}k" in err


def test_liggghts_vtk_dumps_give_the_frames_and_granules_of_its_text_dumps():
    """dump custom/vtk and dump local/gran/vtk of the fixture run (the same frames as its text
    dumps, LIGGGHTS 3.8) through the same reader: the same particles, contacts and granules."""
    pytest.importorskip("vtk")
    from pathlib import Path

    fixture = Path(__file__).parent / "data" / "liggghts_wet_drum"
    text, _ = read_liggghts(sorted(fixture.glob("atoms.*.dump.gz")), sorted(fixture.glob("pairs.*.dump.gz")),
                            DumpMapping.from_toml(fixture / "mapping.toml"), dt=2e-6)
    vtk, meta = read_liggghts(sorted((fixture / "vtk").glob("atoms_*.vtu")), sorted((fixture / "vtk").glob("pairs_*.vtp")),
                              DumpMapping.from_toml(fixture / "vtk" / "mapping.toml"), dt=2e-6)
    assert [s.step for s in vtk] == [s.step for s in text] == [5000, 10000, 15000, 20000]
    assert (vtk[-1].f_cap > 0).sum() > 20
    for a, b in zip(vtk, text):
        oa, ob = np.argsort(a.ids), np.argsort(b.ids)
        np.testing.assert_array_equal(a.ids[oa], b.ids[ob])
        np.testing.assert_allclose(a.position[oa], b.position[ob], rtol=1e-5, atol=0)  # 6 digits against float32
        np.testing.assert_allclose(a.velocity[oa], b.velocity[ob], rtol=1e-5, atol=1e-9)
        np.testing.assert_allclose(a.film_volume[oa], b.film_volume[ob], rtol=1e-5)
        ka, kb = np.lexsort((a.ids[a.contact_j], a.ids[a.contact_i])), np.lexsort((b.ids[b.contact_j], b.ids[b.contact_i]))
        np.testing.assert_array_equal(a.ids[a.contact_i][ka], b.ids[b.contact_i][kb])
        np.testing.assert_allclose(a.gap[ka], b.gap[kb], rtol=1e-5, atol=1e-12)
        np.testing.assert_allclose(a.f_cap[ka], b.f_cap[kb], rtol=1e-4, atol=1e-9)
        for cohesion in ("acting", "bridge"):
            ga_a = {frozenset(a.ids[list(g)]) for g in ga.identify(a, cohesion=cohesion).partition()}
            ga_b = {frozenset(b.ids[list(g)]) for g in ga.identify(b, cohesion=cohesion).partition()}
            assert ga_a == ga_b and (ga_a or not a.n_contacts)


def test_a_dump_whose_radii_are_not_in_metres_is_refused_naming_the_likely_unit(tmp_path, frames):
    import dataclasses

    in_mm = [dataclasses.replace(s, radius=s.radius * 1000, meta=s.meta) for s in frames[:1]]
    pf, cf = write_dumps(tmp_path, in_mm)
    with pytest.raises(DumpFormatError, match=r"atoms.dump, line 9: a particle radius of .* m is not a DEM particle's "
                                              r"in SI units .* likely in millimetres or micrometres"):
        read_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT)


def test_an_error_in_the_reading_worker_reaches_the_command_line_as_one_line(tmp_path, frames, capsys):
    """convert reads in a forked worker; a ValidationError there (whose class does not unpickle)
    still ends the command in one line naming the dump, exit 2, with no file written."""
    pf, cf = write_dumps(tmp_path, frames)
    corrupt(cf[0], lambda ls: ls[:9] + [ls[9], ls[9]] + ls[11:])  # a contact pair twice
    assert _convert(pf, cf, tmp_path) == 2
    err = capsys.readouterr().err.strip()
    assert "duplicate contact pair" in err and "pairs.dump" in err and "\n" not in err
    assert not (tmp_path / "run.h5").exists()


# --- real dump variants: %g ids, periodic boxes, UNITS / TIME items, sparse first contact blocks ---

PAIR_MAPPING = dict(surface_tension=0.1, density=2500.0, drum_omega=2.0, contact_id_i="c_p[1]", contact_id_j="c_p[2]",
                    contact_f_normal=["c_p[3]", "c_p[4]", "c_p[5]"], contact_overlap="c_p[6]")


def _pair_dumps(tmp_path, box_item, box_lines, atoms, pairs):
    """A one-timestep particle dump of ``atoms`` (id, x, y, z; radius 1 mm) and local dump of
    ``pairs`` (text rows), both under ``box_item`` / ``box_lines``."""
    def head(kind, n):
        return ["ITEM: TIMESTEP", "0", f"ITEM: NUMBER OF {kind}", str(n), f"ITEM: BOX BOUNDS {box_item}", *box_lines]

    a = head("ATOMS", len(atoms)) + ["ITEM: ATOMS id x y z vx vy vz omegax omegay omegaz radius"]
    a += [f"{i} {x!r} {y!r} {z!r} 0 0 0 0 0 0 0.001" for i, x, y, z in atoms]
    p = head("ENTRIES", len(pairs)) + ["ITEM: ENTRIES " + " ".join(f"c_p[{k}]" for k in range(1, 7))]
    (tmp_path / "a.dump").write_text("\n".join(a) + "\n")
    (tmp_path / "p.dump").write_text("\n".join(p + pairs) + "\n")
    return [tmp_path / "a.dump"], [tmp_path / "p.dump"]


@pytest.mark.parametrize("box_item, box_lines, atoms, force, periodic", [
    # z periodic, 10 mm: particle 2 at z = 9.8 mm touches particle 1 (0.2 mm) through the face; the
    # force on 1 points +z, away from 2's image at -0.2 mm: repulsive
    ("ff ff pp", ["-0.01 0.01", "-0.01 0.01", "0 0.01"], [(1, 0.0, 0.0, 0.0002), (2, 0.0, 0.0, 0.0098)], "0 0 0.5", "z"),
    # the same box but not periodic: the pair's branch points +z, so the force on 1 pulls (a bridge)
    ("ff ff ff", ["-0.01 0.01", "-0.01 0.01", "0 0.01"], [(1, 0.0, 0.0, 0.0002), (2, 0.0, 0.0, 0.0098)], "0 0 0.5", ""),
    # restricted triclinic, all periodic, tilts xy = 2 mm, xz = -1 mm, yz = 1.5 mm (the bounds widen by
    # them as LAMMPS writes): 2 lies one y-edge (2 mm, 20 mm, 0) from 1's touching image, 1.6 mm off in x
    ("xy xz yz pp pp pp", ["-0.001 0.012 0.002", "0 0.0215 -0.001", "0 0.03 0.0015"],
     [(1, 0.0010, 0.0005, 0.01), (2, 0.0046, 0.0205, 0.01)], "-0.5 0 0", "xyz"),
])
def test_a_contact_through_a_periodic_face_is_taken_between_nearest_images(tmp_path, box_item, box_lines, atoms,
                                                                            force, periodic):
    """The normal-force sign came from the wrapped positions: a compressed contact through a
    periodic face became a bridge pulling with its repulsion (F_coh = 0.5 N)."""
    pf, cf = _pair_dumps(tmp_path, box_item, box_lines, atoms, [f"1 2 {force} 0.0004"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        snapshots, meta = read_liggghts(pf, cf, DumpMapping(**PAIR_MAPPING), dt=DT)
    s = snapshots[0]
    expected = 0.5 if periodic else -0.5
    assert s.f_normal.tolist() == [pytest.approx(expected)] and s.f_cap.tolist() == [pytest.approx(max(-expected, 0))]
    assert meta.provenance["periodic_axes"] == periodic
    said = [str(w.message) for w in caught if "periodic" in str(w.message)]
    assert (said and f"periodic along {periodic}" in said[0] and "a.dump" in said[0]) if periodic else not said


def test_the_nearest_image_of_a_tilted_periodic_box_is_the_shortest_of_its_images():
    from granalytics.convert.lammps import Box

    rng = np.random.default_rng(3)
    for _ in range(20):
        lengths = rng.uniform(1, 2, 3)
        xy, xz, yz = rng.uniform(-0.3, 0.3, 3) * lengths[[0, 0, 1]]
        box = Box(np.array([[lengths[0], xy, xz], [0, lengths[1], yz], [0, 0, lengths[2]]]), (True, True, True))
        near = rng.uniform(-0.2, 0.2, (50, 3))  # short vectors seen through random images
        far = near + (box.edges @ rng.integers(-3, 4, (3, 50))).T
        back = box.minimum_image(far)
        np.testing.assert_allclose(back, near, atol=1e-12)
    half = Box(np.diag([1.0, 1.0, 1.0]), (False, True, False)).minimum_image(np.array([[0.9, 0.9, 0.9]]))
    assert half.tolist() == [[0.9, pytest.approx(-0.1), 0.9]]  # only the periodic axis folds


@pytest.mark.parametrize("written, ok", [("1.23457e+06", False), ("1e+06", False), ("1234567.0", True),
                                         ("1.234567e+06", True), ("0.0", True), ("1.2e3", True)])
def test_contact_ids_written_with_fewer_digits_than_they_have_are_refused(tmp_path, written, ok):
    """dump local writes ids with %g: 1234567 as 1.23457e+06, read as 1234570, another particle."""
    exact = int(float(written)) if ok else 1234567
    pf, cf = _pair_dumps(tmp_path, "ff ff ff", ["-0.01 0.01"] * 3,
                         [(exact, 0.0, 0.0, 0.0), (1234580, 0.0019, 0.0, 0.0), (1234570, 0.005, 0.005, 0.005)],
                         [f"{written} 1234580 0 0 0 0.0001"])
    if ok:
        snapshots, _ = read_liggghts(pf, cf, DumpMapping(**PAIR_MAPPING), dt=DT)
        s = snapshots[0]
        assert sorted(s.ids[[s.contact_i[0], s.contact_j[0]]].tolist()) == sorted([exact, 1234580])
        return
    with pytest.raises(DumpFormatError, match=rf"p.dump, line 10: c_p\[1\] '{re.escape(written)}' is written with \d significant "
                                              r"digits, fewer than the id's 7: .*format float %.16g"):
        read_liggghts(pf, cf, DumpMapping(**PAIR_MAPPING), dt=DT)


def test_units_and_time_items_before_each_timestep_are_read_past(tmp_path, frames):
    """dump_modify units yes / time yes: valid dumps were refused ("expected 'ITEM: TIMESTEP'")."""
    pf, cf = write_dumps(tmp_path, frames)
    corrupt(pf[0], lambda ls: ["ITEM: UNITS", "si"] + [x for l in ls for x in
                                                       (["ITEM: TIME", "0.25", l] if l == "ITEM: TIMESTEP" else [l])])
    snapshots, _ = read_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT)
    assert_same_run(snapshots, frames)
    corrupt(pf[0], lambda ls: ["ITEM: UNITS", "lj"] + ls[2:])
    with pytest.raises(DumpFormatError, match=r"atoms.dump, line 2: the dump is in LAMMPS units 'lj'"):
        read_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT)


def test_the_memory_estimate_counts_contacts_when_the_first_contact_block_is_empty(tmp_path, frames):
    from granalytics.convert.lammps import open_liggghts

    pf, cf = write_dumps(tmp_path, frames)
    full = open_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT).frame_bytes()
    first = frames[0].n_contacts
    corrupt(cf[0], lambda ls: ls[:3] + ["0"] + ls[4:9] + ls[9 + first:])  # a run starting at insertion: no contacts yet
    assert open_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT).frame_bytes() >= 0.9 * full
    particles_only = 40 * 300 * len(ATOM_COLUMNS)
    assert full > particles_only


def test_an_error_about_a_vtk_dump_names_the_file_without_a_line():
    """VTK files have no lines: errors said "atoms_5000.vtu, line -8"."""
    pytest.importorskip("vtk")
    from pathlib import Path

    vtk = Path(__file__).parent / "data" / "liggghts_wet_drum" / "vtk"
    with pytest.raises(DumpFormatError, match=r"atoms_5000\.vtu: no contact dump for timestep 5000$"):
        read_liggghts([vtk / "atoms_5000.vtu", vtk / "atoms_10000.vtu"], [vtk / "pairs_10000.vtp"],
                      DumpMapping.from_toml(vtk / "mapping.toml"), dt=2e-6)


def test_rows_with_a_value_more_than_the_header_names_are_refused(tmp_path, frames):
    """pandas dropped the extra value of every row, with only its own ParserWarning."""
    pf, cf = write_dumps(tmp_path, frames)
    corrupt(pf[0], lambda ls: [l + " 7" if l and l[0] in "-0123456789" and len(l.split()) > 3 else l for l in ls])
    with pytest.raises(DumpFormatError, match=r"atoms.dump, line 10: 14 values for 13 columns"):
        read_liggghts(pf, cf, DumpMapping(**MAPPING), dt=DT)
