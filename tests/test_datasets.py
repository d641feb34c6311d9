import shlex

import numpy as np
import pytest

from granalytics import GranalyticsError
from granalytics.datasets import DATASETS, _main, dataset_path, make_dataset, open_dataset


def _option(command, name):
    argv = shlex.split(command)
    return argv[argv.index(name) + 1] if name in argv else None


@pytest.mark.parametrize("name", sorted(DATASETS))
def test_bundled_dataset_matches_registry_and_its_recipe(name):
    path = dataset_path(name)
    entry = DATASETS[name]
    sim_command, subset_command = entry["commands"]
    with open_dataset(name) as run:
        meta = run.meta
        assert meta.sim_config["params"]["alpha"] == meta.alpha
        assert f"--preset {name}" in sim_command and meta.provenance["code"] == "sim"
        revolutions = float(_option(sim_command, "--revolutions"))
        # the simulator before the frame-grid fix stopped one 0.05-revolution frame short when the
        # revolutions were not a whole number of frame intervals in steps; the registry says so
        assert revolutions - 0.05 - 1e-3 < run.revolutions[-1] < revolutions + 1e-3
        assert meta.provenance["wall_time_s"] > 0  # the simulator's wall time, for CG speed-ups
        kept = meta.provenance["subset_of"]["frames_kept"]
        assert len(run) == len(kept)
        window = _option(subset_command, "--full-window")
        if window is None:  # every frame of the run, 0.05 revolution apart
            assert np.allclose(np.diff(run.revolutions), 0.05, atol=1e-3)
        else:  # every frame inside the window, every fourth before it
            lo, hi = map(float, window.split(":"))
            inside = run.revolutions >= lo - 1e-9
            assert np.allclose(np.diff(run.revolutions[inside]), 0.05, atol=1e-3)
            assert np.allclose(np.diff(run.revolutions[~inside]), 0.2, atol=1e-3)
        assert run[len(run) // 2].n_contacts > 0
    assert path.name == entry["file"]


def test_unknown_or_corrupt_dataset_is_an_error(tmp_path, monkeypatch):
    with pytest.raises(GranalyticsError, match="unknown dataset"):
        dataset_path("nope")
    import granalytics.datasets as ds

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
