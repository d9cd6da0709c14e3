"""Shared fixtures of the Python tests: where the datasets, the CLI and the plugins are.

ctest sets PYTHONPATH to the build tree's python/ folder (python_bindings/CMakeLists.txt) and
the TETHER_* variables below; run by hand:
    PYTHONPATH=build/python TETHER_PLUGIN_BUILD_DIR=build/plugins python3 -m pytest tests/python
"""
import os
import pathlib

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def datasets_dir():
    d = pathlib.Path(os.environ.get("TETHER_DATASETS_DIR", REPO.parent / "shared" / "datasets"))
    if not d.is_dir():
        pytest.skip(f"the public datasets folder {d} is absent (it lives beside the repository)")
    return d


@pytest.fixture(scope="session")
def cli():
    path = os.environ.get("TETHER_CLI", "")
    if not path or not os.access(path, os.X_OK):
        pytest.skip("TETHER_CLI does not name the tether program (ctest sets it)")
    return path


@pytest.fixture(scope="session")
def plugin_dir():
    d = pathlib.Path(os.environ.get("TETHER_PLUGIN_BUILD_DIR", REPO / "build" / "plugins"))
    if not d.is_dir():
        pytest.skip(f"the example plugins folder {d} is absent (TETHER_PLUGIN_BUILD_DIR)")
    return d


@pytest.fixture(scope="session")
def test_plugin_dir():
    d = pathlib.Path(os.environ.get("TETHER_TEST_PLUGIN_DIR", REPO / "build" / "tests" / "plugins"))
    if not d.is_dir():
        pytest.skip(f"the test plugins folder {d} is absent (TETHER_TEST_PLUGIN_DIR)")
    return d
