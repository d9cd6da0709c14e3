"""Every Python example of the README and docs/ runs: the blocks are extracted
(tests/docs/extract_examples.py) and each is run as a script of its own in a folder that holds
what the examples read (intel.g2o from the datasets, the example plugins). A block the docs
mark `<!-- example: not run (WHY) -->` is skipped with its reason."""
import os
import pathlib
import subprocess
import sys

import pytest

import tether

REPO = pathlib.Path(__file__).resolve().parents[2]
PAGES = [REPO / "README.md"] + sorted((REPO / "docs").glob("*.md"))


def _examples(tmp_dir):
    out = tmp_dir / "examples"
    subprocess.run([sys.executable, str(REPO / "tests" / "docs" / "extract_examples.py"), "python", str(out)]
                   + [str(p) for p in PAGES], check=True)
    return sorted(out.glob("*.py"))


def test_there_are_examples_and_each_is_run_or_says_why(tmp_path):
    scripts = _examples(tmp_path)
    assert len(scripts) >= 6
    for s in scripts:
        head = s.read_text().split("\n")[:2]
        if len(head) > 1 and head[1].startswith("# SKIP:"):
            assert len(head[1]) > len("# SKIP: ") + 10, f"{s.name}: a skipped example must say why"


@pytest.fixture(scope="module")
def scripts(tmp_path_factory):
    return _examples(tmp_path_factory.mktemp("docs"))


def test_every_python_example_runs(scripts, tmp_path, datasets_dir, plugin_dir):
    work = tmp_path / "work"
    work.mkdir()
    intel = datasets_dir / "g2o" / "intel.g2o"
    if intel.exists():
        (work / "intel.g2o").symlink_to(intel.resolve())
    for plugin in plugin_dir.glob("*.so"):
        (work / plugin.name).symlink_to(plugin.resolve())
    env = dict(os.environ)
    # The module these tests import, wherever the scripts run.
    env["PYTHONPATH"] = os.pathsep.join([str(pathlib.Path(tether.__file__).resolve().parent)]
                                        + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    ran, skipped = [], []
    for script in scripts:
        text = script.read_text()
        where = text.split("\n")[0][2:]
        if "\n# SKIP:" in text.split("\n", 2)[0] + "\n" + text.split("\n", 2)[1]:
            skipped.append(where)
            continue
        if '"intel.g2o"' in text and not intel.exists():
            skipped.append(f"{where} (needs {intel})")
            continue
        r = subprocess.run([sys.executable, str(script)], cwd=work, env=env, capture_output=True, text=True,
                           timeout=300)
        assert r.returncode == 0, f"{where} failed:\n{r.stdout}\n{r.stderr}"
        ran.append(where)
    print(f"{len(ran)} Python examples ran: {', '.join(ran)}; skipped: {', '.join(skipped) or 'none'}")
    assert len(ran) >= 4
