"""The examples gallery (``examples/``): jupytext percent scripts that use the Python API only.

Fast: each script is a jupytext notebook that reads ecostudy through ``ecostudy.api`` alone and
runs no command in a subprocess (every command is an API function).
Slow: each is converted to a notebook and executed by a Jupyter kernel (nbclient), as the docs
render it; a cell that raises fails the test, and every example shows at least one figure.
"""
import ast
import subprocess
import sys
from pathlib import Path

import jupytext
import nbclient
import pytest

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "examples").glob("[0-9][0-9]_*.py"))


def test_the_gallery_has_its_examples():
    assert 4 <= len(EXAMPLES) <= 6, [p.name for p in EXAMPLES]


@pytest.mark.parametrize("script", EXAMPLES, ids=lambda p: p.stem)
def test_an_example_is_a_notebook_that_uses_the_python_api_only(script):
    nb = jupytext.read(script)
    kinds = [cell.cell_type for cell in nb.cells]
    assert kinds[0] == "markdown" and nb.cells[0].source.startswith("# "), "a title first"
    assert kinds.count("code") >= 2 and kinds.count("markdown") >= 2
    imported = set()
    for node in ast.walk(ast.parse(script.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module:
            imported |= {f"{node.module}.{a.name}" for a in node.names}
        elif isinstance(node, ast.Import):
            imported |= {a.name for a in node.names}
    ours = {name for name in imported if name.split(".")[0] == "ecostudy"}
    assert ours == {"ecostudy.api"}, sorted(ours)
    shelled = {name for name in imported if name.split(".")[0] in ("subprocess", "os")}
    assert not shelled, f"every command is an api function: no {sorted(shelled)}"


def test_the_shipped_files_are_found_from_a_folder_outside_the_repository(tmp_path):
    """The examples looked for tracks/ in the working directory, the folders above it and
    ``Path(api.__file__).parents[1]``: the ecostudy package, not the repository, so run from /tmp they
    stopped on a bare StopIteration. ``api.shipped`` finds the checkout the package is installed
    from, and names where it looked for a file it cannot find."""
    code = ("from ecostudy import api\nprint(api.shipped('tracks/amsterdam_rokin_centraal.yaml'))\n"
            "try:\n    api.shipped('tracks/nowhere.yaml')\nexcept api.InputError as e:\n    print(e)")
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    found, refused = done.stdout.splitlines()
    assert Path(found) == ROOT / "tracks" / "amsterdam_rokin_centraal.yaml"
    assert refused.startswith("arguments: name: tracks/nowhere.yaml is not in ") and str(ROOT) in refused, refused


@pytest.mark.parametrize("script", EXAMPLES, ids=lambda p: p.stem)
def test_an_example_finds_its_files_with_the_api(script):
    text = script.read_text()
    assert "__file__" not in text and "api.shipped(" in text


@pytest.mark.slow
@pytest.mark.parametrize("script", EXAMPLES, ids=lambda p: p.stem)
def test_an_example_runs_from_top_to_bottom(script, tmp_path):
    nb = jupytext.read(script)
    client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(ROOT / "examples")}})
    client.execute()  # CellExecutionError on the first cell that raises
    outputs = [o for cell in nb.cells if cell.cell_type == "code" for o in cell.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    assert any("image/png" in o.get("data", {}) for o in outputs), "no figure shown"
