import dataclasses

import numpy as np
import pytest

from granalytics import RunMeta, Snapshot, ValidationError
from conftest import make_meta, make_snapshot


def fields(snapshot):
    return {f.name: getattr(snapshot, f.name) for f in dataclasses.fields(snapshot)}


def rebuilt(snapshot, **changes):
    data = fields(snapshot)
    data.update(changes)
    return Snapshot(**data)


@pytest.fixture
def snap():
    return make_snapshot(5, [(0, 1), (1, 2), (3, 4)])


def test_valid_snapshot_is_coerced_to_canonical_dtypes(snap):
    s = rebuilt(snap, ids=snap.ids.astype(np.int32), radius=snap.radius.astype(np.float32),
                contact_i=snap.contact_i.astype(np.uint16))
    assert s.ids.dtype == np.int64 and s.radius.dtype == np.float64 and s.contact_i.dtype == np.int64
    assert s.n_particles == 5 and s.n_contacts == 3


def test_column_views_are_stored_in_c_order(snap):
    pairs = np.stack([snap.contact_i, snap.contact_j], axis=1)
    s = rebuilt(snap, contact_i=pairs[:, 0], contact_j=pairs[:, 1], velocity=np.asfortranarray(snap.velocity))
    assert s.contact_i.flags.c_contiguous and s.contact_j.flags.c_contiguous and s.velocity.flags.c_contiguous
    assert np.array_equal(s.contact_j, snap.contact_j) and np.array_equal(s.velocity, snap.velocity)


@pytest.mark.parametrize(
    "field, value, index, words",
    [
        ("position", lambda s: np.where(np.arange(15).reshape(5, 3) == 7, np.nan, s.position), 2, "non-finite"),
        ("velocity", lambda s: np.where(np.arange(15).reshape(5, 3) == 14, np.inf, s.velocity), 4, "non-finite"),
        ("radius", lambda s: np.array([1e-3, 1e-3, 0.0, 1e-3, -1.0]), 2, "> 0"),
        ("film_volume", lambda s: np.array([0, 0, 0, -1e-12, 0.0]), 3, ">= 0"),
        ("f_cap", lambda s: np.array([1e-4, -1e-6, 1e-4]), 1, ">= 0"),
        ("bridge_volume", lambda s: np.array([0, 0, -1.0]), 2, ">= 0"),
        ("gap", lambda s: np.array([0, np.nan, 0]), 1, "non-finite"),
        ("contact_j", lambda s: np.array([1, 2, 5]), 2, "out of range"),
        ("contact_i", lambda s: np.array([0, -1, 3]), 1, "out of range"),
    ],
)
def test_invalid_values_name_field_and_first_index(snap, field, value, index, words):
    with pytest.raises(ValidationError) as err:
        rebuilt(snap, **{field: value(snap)})
    assert err.value.field == field and err.value.index == index
    assert words in str(err.value) and f"index {index}" in str(err.value)


def test_self_pair_reversed_pair_and_duplicate_pair_are_rejected(snap):
    with pytest.raises(ValidationError, match="paired with itself") as err:
        rebuilt(snap, contact_j=np.array([1, 1, 4]))
    assert err.value.index == 1
    with pytest.raises(ValidationError, match="not ordered"):
        rebuilt(snap, contact_i=np.array([1, 1, 3]), contact_j=np.array([0, 2, 4]))
    with pytest.raises(ValidationError, match=r"duplicate contact pair \(1, 2\)") as err:
        rebuilt(snap, contact_i=np.array([1, 0, 1]), contact_j=np.array([2, 1, 2]))
    assert err.value.index == 2


def test_duplicate_ids_shapes_and_dtypes_are_rejected(snap):
    with pytest.raises(ValidationError, match="duplicate particle id") as err:
        rebuilt(snap, ids=np.array([0, 1, 2, 1, 4]))
    assert err.value.index == 3
    with pytest.raises(ValidationError, match=r"shape \(n,3\)"):
        rebuilt(snap, position=snap.position[:, :2])
    with pytest.raises(ValidationError, match="expected 5"):
        rebuilt(snap, radius=snap.radius[:4])
    with pytest.raises(ValidationError, match="integer dtype"):
        rebuilt(snap, contact_i=snap.contact_i.astype(float))
    with pytest.raises(ValidationError, match="real numeric dtype"):
        rebuilt(snap, radius=snap.radius.astype(complex))
    with pytest.raises(ValidationError, match="time"):
        rebuilt(snap, time=float("nan"))
    with pytest.raises(ValidationError, match="step"):
        rebuilt(snap, step=-3)
    with pytest.raises(ValidationError, match=r"^field 'time': must be a finite number, got str '1.5'$"):
        rebuilt(snap, time="1.5")  # text is not read as a number
    with pytest.raises(ValidationError, match=r"^field 'step': must be a whole number >= 0, got float 3.0$"):
        rebuilt(snap, step=3.0)


def test_empty_contacts_are_valid():
    s = make_snapshot(3, [])
    assert s.n_contacts == 0 and s.contact_i.dtype == np.int64


def test_take_particles_reindexes_contacts_and_keeps_pairs_ordered(snap):
    order = np.array([4, 2, 0, 3, 1])
    p = snap.take_particles(order)
    assert np.array_equal(p.ids, snap.ids[order])
    assert (p.contact_i < p.contact_j).all()
    pairs = {frozenset((p.ids[i], p.ids[j])) for i, j in zip(p.contact_i, p.contact_j)}
    assert pairs == {frozenset((snap.ids[i], snap.ids[j])) for i, j in zip(snap.contact_i, snap.contact_j)}
    with pytest.raises(ValidationError):
        snap.take_particles([0, 0, 1, 2, 3])


def test_run_meta_defaults_and_validation():
    m = make_meta(1000, alpha=2.0)
    assert m.n_particles_original == 8000 and m.mean_radius_original == pytest.approx(0.75e-3)
    assert RunMeta.from_dict(m.to_dict()) == m
    with pytest.raises(ValidationError, match="surface_tension"):
        make_meta(10, surface_tension=-1)
    with pytest.raises(ValidationError, match="contact_angle"):
        make_meta(10, contact_angle=2.0)
    with pytest.raises(ValidationError, match="n_particles"):
        make_meta(0)
    with pytest.raises(ValidationError, match=r"^field 'n_particles': must be a whole number >= 1, got float 5.0$"):
        make_meta(5.0)  # a count, not a measurement
    with pytest.raises(ValidationError, match=r"^field 'sim_config.params.dt': must be a finite number, got float nan$"):
        make_meta(10, sim_config={"params": {"dt": float("nan")}})
    with pytest.raises(ValidationError, match="JSON"):
        make_meta(10, provenance={"x": object()})
    for first in (-1, 2.5, "4"):  # a part's first frame (sim run --resume-from): a whole number >= 0
        with pytest.raises(ValidationError, match="field 'provenance.first_frame'"):
            make_meta(10, provenance={"first_frame": first})
    assert make_meta(10, provenance={"first_frame": 40}).provenance["first_frame"] == 40
    with pytest.warns(UserWarning, match="unknown keys"):
        m2 = RunMeta.from_dict(dict(m.to_dict(), future_field=3))
    assert m2.provenance["unknown_meta"] == {"future_field": 3}


def test_a_frame_without_particles_is_refused_with_a_clear_message():
    empty = {name: np.zeros((0, 3) if name in ("position", "velocity", "angular_velocity") else 0)
             for name in ("radius", "position", "velocity", "angular_velocity", "film_volume", "f_cap", "f_normal",
                          "gap", "bridge_volume")}
    with pytest.raises(ValidationError, match="no particles") as err:
        Snapshot(time=0.0, step=0, ids=np.zeros(0, np.int64), contact_i=np.zeros(0, np.int64),
                 contact_j=np.zeros(0, np.int64), **empty)
    assert err.value.field == "ids" and "\n" not in str(err.value)


def test_run_meta_json_fields_must_be_dicts_that_json_stores_unchanged():
    loop = {}
    loop["again"] = loop
    for field, value, words in [
        ("sim_config", "not a dict", "must be a dict"),
        ("provenance", ["a", "list"], "must be a dict"),
        ("provenance", loop, "Circular reference"),
        ("sim_config", {"params": {1: 2.0}}, r"key 1 in \['params'\] is not a string"),
        ("provenance", {"files": [{"size": {3}}]}, "set is not JSON serializable"),
    ]:
        with pytest.raises(ValidationError, match=words) as err:
            make_meta(10, **{field: value})
        assert err.value.field == field, (field, value)
    m = make_meta(10, provenance={"ok": [1, 2.5, None, "x", {"nested": True}]})
    m.sim_config = {"when": object()}  # changed after construction: validate() catches it
    with pytest.raises(ValidationError, match="field 'sim_config'"):
        m.validate()


def test_a_snapshot_prints_as_one_line():
    """print(snapshot) printed every array of the frame (~500 lines)."""
    s = make_snapshot(4, [(0, 1), (1, 2)], [0.5, 0.7], time=1.5, step=300)
    text = repr(s)
    assert "\n" not in text and len(text) < 120 and str(s) == text
    assert f"{s.n_particles} particles" in text and f"{s.n_contacts} contacts" in text and f"step {s.step}" in text
