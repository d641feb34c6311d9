"""Contact graphs in and out, user edge criteria, and the ParaView export."""

import xml.etree.ElementTree as ET

import meshio
import networkx as nx
import numpy as np
import pytest

import granalytics as ga
from granalytics import ParameterError
from granalytics.cli import main
from granalytics.identification.edges import contact_table, edge_table, to_igraph, to_networkx
from granalytics.export.vtk import export_vtk
from granalytics.datasets.synthetic import synthetic_snapshot, write_synthetic_run


@pytest.fixture(scope="module")
def snapshot():
    return synthetic_snapshot(1500, seed=12)


def test_custom_expression_reproduces_gna_and_callables_work(snapshot):
    gna = ga.identify(snapshot, c_agg=0.5, a_agg_deg=30)
    expr = ga.identify(snapshot, method="custom", criterion="f_norm >= 0.5 and (angle_v_deg < 30 or angle_w_deg < 30)")
    assert expr.partition() == gna.partition() and gna.n_granules > 0
    wet = ga.identify(snapshot, method="custom", criterion=lambda t: (t.bridge_volume > 0).to_numpy())
    assert wet.n_granulated >= gna.n_granulated
    with pytest.raises(ParameterError, match="failed"):
        ga.identify(snapshot, method="custom", criterion="no_such_column > 1")
    with pytest.raises(ParameterError, match="one boolean per contact"):
        ga.identify(snapshot, method="custom", criterion=lambda t: np.ones(3, bool))


def test_kept_graph_exports_agree_with_labels(snapshot):
    r = ga.identify(snapshot)
    edges = edge_table(r)
    assert len(edges) == r.kept.sum() and (edges.granule >= 0).all()
    g = to_networkx(r)
    assert g.number_of_nodes() == snapshot.n_particles and g.number_of_edges() == len(edges)
    comps = {frozenset(c) for c in nx.connected_components(g) if len(c) >= 2}
    assert comps == r.partition()
    ig = to_igraph(r)
    assert ig.ecount() == len(edges) and ig.vs["id"] == snapshot.ids.tolist()
    table = contact_table(snapshot)
    assert len(table) == snapshot.n_contacts and table.f_norm.max() > 0


def test_vtk_export_reads_back_with_meshio(tmp_path, snapshot):
    frames = [synthetic_snapshot(400, time=0.1 * k, seed=k) for k in range(3)]
    pvd = export_vtk(frames, tmp_path / "vtk", c_agg=0.5)
    files = [d.get("file") for d in ET.parse(pvd).getroot().iter("DataSet")]
    assert files == ["frame_00000.vtu", "frame_00001.vtu", "frame_00002.vtu"]
    mesh = meshio.read(tmp_path / "vtk" / files[1])
    s = frames[1]
    r = ga.identify(s, c_agg=0.5)
    np.testing.assert_array_equal(mesh.points, s.position)
    np.testing.assert_array_equal(mesh.point_data["granule"], r.labels)
    np.testing.assert_array_equal(mesh.point_data["radius"], s.radius)
    lines = mesh.cells_dict["line"]
    np.testing.assert_array_equal(lines, np.column_stack([s.contact_i, s.contact_j]))
    kept = mesh.cell_data_dict["kept"]["line"]
    np.testing.assert_array_equal(kept.astype(bool), r.kept)
    sizes = mesh.point_data["granule_size"]
    assert (sizes[r.labels >= 0] >= 2).all() and (sizes[r.labels < 0] == 1).all()


def test_export_vtk_cli(tmp_path, capsys):
    run = write_synthetic_run(tmp_path / "r.h5", n_particles=300, revolutions=1.0, frames_per_revolution=4)
    assert main(["export-vtk", run, "--out", str(tmp_path / "out"), "--quiet"]) == 0
    assert len(list((tmp_path / "out").glob("*.vtu"))) == 5 and (tmp_path / "out" / "run.pvd").exists()


def test_frame_figure_renders_granules(snapshot, tmp_path):
    from granalytics.report.figures import frame_figure

    fig = frame_figure(ga.identify(snapshot))
    fig.savefig(tmp_path / "f.png")
    assert (tmp_path / "f.png").stat().st_size > 10_000


def test_export_carries_granule_track_ids_and_the_drum(tmp_path):
    """granule_track: a granule that continues keeps its id (the tracker's); a run with the drum's
    geometry gets a drum surface per frame at the angle Ω·t, listed in the .pvd as part 1."""
    import math
    import xml.etree.ElementTree as ET

    import meshio

    from granalytics.export.vtk import drum_mesh, export_vtk
    from granalytics.datasets.synthetic import write_synthetic_run
    from granalytics.analysis.particle_tables import granule_tracks

    path = write_synthetic_run(tmp_path / "run.h5", n_particles=150, revolutions=0.5, frames_per_revolution=8, seed=2)
    with ga.open_run(path) as run:
        pvd = export_vtk(run, tmp_path / "vtk", c_agg=0.5)
        labels, tracks = granule_tracks(run, c_agg=0.5)
    for k in range(len(labels)):
        mesh = meshio.read(tmp_path / "vtk" / f"frame_{k:05d}.vtu")
        mapping = tracks.labels_to_tracks[k]
        expected = np.where(labels[k] >= 0, mapping[np.maximum(labels[k], 0)], -1)
        assert np.array_equal(mesh.point_data["granule_track"], expected)
    parts = {d.get("part") for d in ET.parse(pvd).getroot().iter("DataSet")}
    assert parts == {"0"}  # a synthetic run has no drum geometry
    geometry = {"drum_radius": 0.1, "drum_length": 0.045, "n_baffles": 4, "baffle_height": 0.15, "drum_omega": 2.0}
    drum = drum_mesh(geometry, time_s=math.pi / 4)  # Ω·t = 2 rad/s × π/4 s = 90°
    baffle = drum.points[-16:-12]  # the first baffle's four corners
    angle = math.atan2(baffle[1, 1], baffle[1, 0])
    assert angle == pytest.approx(math.pi / 2) and np.hypot(*baffle[0, :2]) == pytest.approx(0.085)
    assert drum.points[:, 2].max() == pytest.approx(0.045)


def test_export_writes_the_track_ids_of_the_continuation_rule(tmp_path):
    """Main-branch ids by default, the strict rule's with continuation="strict"; a bad value is
    refused before anything is written."""
    from granalytics.analysis.particle_tables import granule_tracks

    path = write_synthetic_run(tmp_path / "run.h5", n_particles=200, revolutions=1.0, frames_per_revolution=8, seed=4)
    written = {}
    with ga.open_run(path) as run:
        for rule in ("main", "strict"):
            export_vtk(run, tmp_path / rule, c_agg=0.5, **({} if rule == "main" else {"continuation": rule}))
            labels, tracks = granule_tracks(run, c_agg=0.5, continuation=rule)
            written[rule] = []
            for k in range(len(labels)):
                got = meshio.read(tmp_path / rule / f"frame_{k:05d}.vtu").point_data["granule_track"]
                mapping = tracks.labels_to_tracks[k]
                assert np.array_equal(got, np.where(labels[k] >= 0, mapping[np.maximum(labels[k], 0)], -1))
                written[rule].append(got)
        assert any((a != b).any() for a, b in zip(written["main"], written["strict"]))
        with pytest.raises(ParameterError, match="^export_vtk: continuation must be one of 'main', 'strict', got str 'longest'$"):
            export_vtk(run, tmp_path / "bad", c_agg=0.5, continuation="longest")
    assert not (tmp_path / "bad").exists()
