"""docs/example.ipynb runs top to bottom and its stored outputs are what it
prints and shows now (tests/notebook.py runs it as Jupyter would)."""
import base64
import io
import json
from pathlib import Path

import numpy as np
from PIL import Image

from tests.notebook import outputs_of, run

NOTEBOOK = Path(__file__).resolve().parents[1] / "docs" / "example.ipynb"


def test_example_notebook_runs_and_matches_its_stored_outputs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    stored = [c for c in json.loads(NOTEBOOK.read_text())["cells"] if c["cell_type"] == "code"]
    results = run(NOTEBOOK)
    assert len(results) == len(stored)
    pictures = 0
    for count, ((printed, value), cell) in enumerate(zip(results, stored), 1):
        now = outputs_of(printed, value, count)
        assert [o["output_type"] for o in now] == [o["output_type"] for o in cell["outputs"]]
        for new, old in zip(now, cell["outputs"]):
            if new["output_type"] == "stream":
                assert new["text"] == old["text"]
                continue
            assert new["data"].keys() == old["data"].keys()
            if "image/png" in new["data"]:
                pictures += 1
                a, b = (np.asarray(Image.open(io.BytesIO(base64.b64decode(d["image/png"]))))
                        for d in (new["data"], old["data"]))
                assert a.shape == (240, 320, 3) and np.array_equal(a, b)
            elif "render_s" not in "".join(old["data"]["text/plain"]):   # a time differs run to run
                assert new["data"]["text/plain"] == old["data"]["text/plain"]
    assert pictures == 1
    assert (tmp_path / "spheres.pfm").is_file()
