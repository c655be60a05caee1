"""The notebooks of examples/notebooks run from top to bottom without an error and show their
plots (executed by nbclient in a fresh kernel, as Jupyter would, with the outputs of their runs
in a temporary directory)."""

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
NOTEBOOKS = sorted((ROOT / "examples" / "notebooks").glob("*.ipynb"))


def _client():
    try:
        import nbclient
        import nbformat
        from jupyter_client.kernelspec import KernelSpecManager
        import matplotlib  # noqa: F401 (the notebooks plot)
    except ImportError as e:
        print(f"note: the notebooks were not executed: {e.name} not available (pip install nbclient nbformat ipykernel matplotlib)")
        pytest.skip(f"skipped: {e.name} not available (pip install nbclient nbformat ipykernel matplotlib)")
    if "python3" not in KernelSpecManager().find_kernel_specs():
        print("note: the notebooks were not executed: no python3 kernel (pip install ipykernel)")
        pytest.skip("skipped: no python3 Jupyter kernel (pip install ipykernel)")
    return nbclient, nbformat


def test_there_are_notebooks():
    names = {p.name for p in NOTEBOOKS}
    assert {"e1_config_to_pulse.ipynb", "e2_reading_outputs.ipynb", "e3_response_profile.ipynb"} <= names, names


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs_and_shows_its_plots(path, tmp_path, monkeypatch):
    nbclient, nbformat = _client()
    nb = nbformat.read(path, as_version=4)
    # committed without outputs: what is shown comes from this run
    assert all(not c.get("outputs") for c in nb.cells if c.cell_type == "code"), f"{path.name} holds outputs"
    monkeypatch.setenv("GRAINWAVE_OUT", str(tmp_path))  # the kernel inherits the environment
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    assert any("image/png" in o.get("data", {}) for o in outputs), f"{path.name} shows no plot"
    assert (tmp_path / "notebooks").is_dir()
