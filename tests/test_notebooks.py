"""The comparison notebooks in docs/notebooks run from top to bottom on the bundled data (so they
never rot), and are committed without outputs."""

from pathlib import Path

import nbformat
import pytest
import zmq
from jupyter_client.manager import AsyncKernelManager
from nbclient import NotebookClient

NOTEBOOKS = sorted((Path(__file__).parents[1] / "docs" / "notebooks").glob("*.ipynb"))


def test_the_notebooks_are_there():
    assert {p.name for p in NOTEBOOKS} >= {"cg_comparison.ipynb", "threshold_sensitivity.ipynb", "method_comparison.ipynb"}


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_is_stripped_and_runs(path, tmp_path):
    nb = nbformat.read(path, as_version=4)
    for cell in nb.cells:
        if cell.cell_type == "code":
            assert not cell.outputs and cell.execution_count is None, f"{path.name}: outputs committed"
    # encrypted sockets where the kernel supports them: no warning about unencrypted TCP
    kernel = AsyncKernelManager(kernel_name="python3", transport_encryption="auto" if zmq.has("curve") else "disabled")
    NotebookClient(nb, km=kernel, timeout=300, resources={"metadata": {"path": str(tmp_path)}}).execute()
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert not errors
    images = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if "image/png" in o.get("data", {})]
    assert images, f"{path.name}: no figure was drawn"
    # progress bars are widgets in Jupyter: without ipywidgets every notebook printed
    # "TqdmWarning: IProgress not found" (and drew text bars)
    streams = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.outputs
                      if o.output_type == "stream")
    assert "IProgress not found" not in streams and "TqdmWarning" not in streams
