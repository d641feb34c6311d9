"""The cohesion convention: which force counts as F_coh ("acting" vs "bridge")."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import granalytics as ga
from granalytics.identification.cohesion import cohesion_counts, cohesive_force
from granalytics.base.errors import ParameterError
from granalytics.convert.lammps import DumpMapping, read_liggghts

from conftest import make_meta, make_snapshot

FIXTURE = Path(__file__).parent / "data" / "liggghts_wet_drum"


def chain(gaps, meta=None):
    """Four particles in a row, joined by three wet pairs of strength f = 0.8 with these gaps [m]."""
    s = make_snapshot(4, [(0, 1), (1, 2), (2, 3)], [0.8, 0.8, 0.8], meta=meta)
    return dataclasses.replace(s, gap=np.asarray(gaps, dtype=float))


def test_acting_counts_only_separated_bridges_unless_the_run_applied_capillary_force_in_contact():
    s = chain([1e-5, -1e-6, 0.0])  # separated, overlapping, exactly touching
    assert cohesion_counts(s, "acting").tolist() == [True, False, False]
    np.testing.assert_array_equal(cohesive_force(s, "acting"), [s.f_cap[0], 0.0, 0.0])
    assert cohesive_force(s, "bridge") is s.f_cap
    in_contact = chain([1e-5, -1e-6, 0.0], meta=make_meta(4, capillary_in_contact=True))
    np.testing.assert_array_equal(cohesive_force(in_contact, "acting"), in_contact.f_cap)


def test_every_method_follows_the_convention():
    s = chain([1e-5, -1e-6, 1e-5])  # 0-1 and 2-3 pull, 1-2 touches
    for method, params in [("gna", {}), ("community", {"c_agg": 0.5, "resolution": 0.01}), ("sieve", {"connect": "gna"}),
                           ("custom", {"criterion": "f_norm >= 0.6"}), ("dbscan", {"bridged_only": True, "eps_diameters": 1.1})]:
        acting = ga.identify(s, method=method, **params)
        bridge = ga.identify(s, method=method, cohesion="bridge", **params)
        assert acting.sizes.tolist() == [2, 2], method
        assert bridge.sizes.tolist() == [4], method
        assert acting.params["cohesion"] == "acting" and bridge.params["cohesion"] == "bridge"


def test_unknown_convention_is_refused_with_its_name():
    with pytest.raises(ParameterError, match="cohesion must be one of"):
        ga.identify(chain([1e-5] * 3), cohesion="touching")
    with pytest.raises(ParameterError, match="cohesion"):
        ga.sensitivity([chain([1e-5] * 3)], [0.5], [20], cohesion="both")


def test_sensitivity_and_run_stats_carry_the_convention():
    frames = [chain([1e-5, -1e-6, 1e-5]), dataclasses.replace(chain([-1e-6, -1e-6, 1e-5]), time=1.0, step=10)]
    for cohesion, sizes in (("acting", [2, 1]), ("bridge", [1, 1])):
        table = ga.sensitivity(frames, [0.6], [20], cohesion=cohesion)
        assert (table["cohesion"] == cohesion).all()
        assert table["n_granules"].tolist() == sizes
        ts = ga.run_stats(frames, cohesion=cohesion)
        assert (ts["cohesion"] == cohesion).all() and ts["n_granules"].tolist() == sizes


def test_capillary_in_contact_is_read_from_sim_config_and_survives_the_run_file(tmp_path):
    meta = make_meta(4, sim_config={"params": {"capillary_in_contact": True}})
    assert meta.capillary_in_contact is True
    assert make_meta(4).capillary_in_contact is False
    with pytest.raises(ga.ValidationError, match="capillary_in_contact"):
        make_meta(4, capillary_in_contact="yes")
    path = tmp_path / "run.h5"
    with ga.RunWriter(path, make_meta(4, capillary_in_contact=True)) as writer:
        writer.append(chain([1e-5, -1e-6, 1e-5], meta=writer.meta))
    with ga.open_run(path) as run:
        assert run.meta.capillary_in_contact is True
        assert ga.identify(run[0]).sizes.tolist() == [4]


def test_liggghts_cohesion_is_the_attractive_part_of_the_signed_normal_force():
    mapping = DumpMapping.from_toml(FIXTURE / "mapping.toml")
    snapshots, meta = read_liggghts(sorted(FIXTURE.glob("atoms.*.dump.gz")), sorted(FIXTURE.glob("pairs.*.dump.gz")),
                                    mapping, dt=2e-6)
    s = snapshots[-1]
    assert meta.capillary_in_contact is True
    # f_normal is signed (positive = repulsive); F_coh is its attractive part, nothing else
    np.testing.assert_array_equal(s.f_cap, np.maximum(-s.f_normal, 0.0))
    separated, touching = s.gap > 0, s.gap < 0
    assert (s.f_normal[separated] < 0).all()  # a separated bridge pulls
    compressed = touching & (s.f_normal > 0)
    assert compressed.sum() > 10 and (s.f_cap[compressed] == 0).all()  # a compressed contact is no cohesion
    # both conventions agree for data whose F_coh is what acted
    np.testing.assert_array_equal(cohesive_force(s, "acting"), cohesive_force(s, "bridge"))


def test_sim_runs_count_no_cohesion_between_touching_particles():
    from granalytics.datasets import open_dataset

    with open_dataset("lab-cg3") as run:
        s = run[len(run) - 1]
    assert s.meta.capillary_in_contact is False
    touching = s.gap <= 0
    wet_touching = touching & (s.f_cap > 0)
    assert wet_touching.sum() > 10  # the bridge of a touching wet pair is recorded ...
    assert (cohesive_force(s, "acting")[touching] == 0).all()  # ... but is not cohesion that acted
    acting = ga.identify(s, c_agg=0.6, a_agg_deg=20)
    bridge = ga.identify(s, c_agg=0.6, a_agg_deg=20, cohesion="bridge")
    assert acting.n_granulated < bridge.n_granulated
