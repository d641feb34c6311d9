import pytest

from granalytics import GranalyticsError
from granalytics.datasets import DATASETS, dataset_path, open_dataset


@pytest.mark.parametrize("name", sorted(DATASETS))
def test_bundled_dataset_matches_registry_and_is_a_sim_run(name):
    path = dataset_path(name)
    with open_dataset(name) as run:
        assert len(run) > 100
        meta = run.meta
        assert meta.sim_config["params"]["alpha"] == meta.alpha
        assert run.revolutions[-1] > 5.99
        assert run[len(run) // 2].n_contacts > 0
    assert path.name == DATASETS[name]["file"]


def test_unknown_or_corrupt_dataset_is_an_error(tmp_path, monkeypatch):
    with pytest.raises(GranalyticsError, match="unknown dataset"):
        dataset_path("nope")
    import granalytics.datasets as ds

    monkeypatch.setitem(ds.DATASETS, "fake", {"file": "fake.h5", "sha256": "0" * 64, "command": "x"})
    monkeypatch.setattr(ds, "DATASET_DIR", tmp_path)
    with pytest.raises(GranalyticsError, match="missing"):
        dataset_path("fake")
    (tmp_path / "fake.h5").write_bytes(b"x")
    with pytest.raises(GranalyticsError, match="does not match"):
        dataset_path("fake")
