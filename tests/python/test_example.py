"""examples/python/optimize_and_plot.py runs and draws its picture (SVG, written by itself)."""
import os
import pathlib
import subprocess
import sys

REPO = pathlib.Path(__file__).resolve().parents[2]


def test_example_optimises_and_writes_an_svg(tmp_path):
    out = tmp_path / "laps.svg"
    r = subprocess.run([sys.executable, str(REPO / "examples" / "python" / "optimize_and_plot.py"), "--svg", "-o",
                        str(out)], capture_output=True, text=True, env=dict(os.environ))
    assert r.returncode == 0, r.stderr
    assert "converged" in r.stdout
    svg = out.read_text()
    assert svg.startswith("<svg") and svg.count("<polyline") == 2
