"""A tiny notebook runner: executes a notebook's code cells in order in one
namespace, as Jupyter would, and records each cell's printed text and its
last expression's display (PNG if it has ``_repr_png_``, else its repr).

    python tests/notebook.py docs/example.ipynb    # run it, store the outputs

nbclient would need a kernel, ZeroMQ and Jupyter's client: too much for
a test of a few cells.
"""
import ast
import base64
import contextlib
import io
import json
import sys
from pathlib import Path


def run_cell(source, namespace):
    """(printed text, last expression's value or None) of one code cell."""
    tree = ast.parse(source)
    last = None
    if tree.body and isinstance(tree.body[-1], ast.Expr):
        last = ast.Expression(tree.body.pop().value)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(tree, "<cell>", "exec"), namespace)
        value = eval(compile(last, "<cell>", "eval"), namespace) if last is not None else None
    return out.getvalue(), value


def outputs_of(printed, value, count):
    outputs = []
    if printed:
        outputs.append({"name": "stdout", "output_type": "stream",
                        "text": printed.splitlines(keepends=True)})
    if value is not None:
        data = {"text/plain": repr(value).splitlines(keepends=True)}
        png = getattr(value, "_repr_png_", None)
        png = png() if png is not None else None
        if png:
            data["image/png"] = base64.b64encode(png).decode()
        outputs.append({"data": data, "execution_count": count, "metadata": {},
                        "output_type": "execute_result"})
    return outputs


def run(path, store=False):
    """Run the notebook at ``path``; returns [(printed, value)] per code cell."""
    nb = json.loads(Path(path).read_text())
    namespace = {"__name__": "__main__"}
    results = []
    count = 0
    for cell in nb["cells"]:
        if cell["cell_type"] != "code":
            continue
        count += 1
        printed, value = run_cell("".join(cell["source"]), namespace)
        results.append((printed, value))
        cell["execution_count"] = count
        cell["outputs"] = outputs_of(printed, value, count)
    if store:
        Path(path).write_text(json.dumps(nb, indent=1) + "\n")
    return results


if __name__ == "__main__":
    run(sys.argv[1], store=True)
