"""Fixtures of the pytest suite of the Python module (doc/python.md): rendered synthetic clips and the built tools.

CTest runs the suite twice (python/CMakeLists.txt): `-m "not e2e"` (python_unit) and `-m e2e` (python_e2e, against
slam-run and slam-eval). PRIORSLAM_BIN_DIR and PRIORSLAM_SOURCE_DIR name the build's tools and the source tree.
"""
import json
import os
import pathlib
import subprocess

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("PRIORSLAM_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
BIN_DIR = pathlib.Path(os.environ.get("PRIORSLAM_BIN_DIR", SOURCE_DIR / "build" / "bin"))
CONFIG = SOURCE_DIR / "config" / "slam" / "synthetic.ini"


def pytest_configure(config):
    config.addinivalue_line("markers", "e2e: compares the module with the built tools (slam-run, slam-eval)")


def tool(name):
    path = BIN_DIR / name
    if not path.exists():
        raise RuntimeError(f"{path}: not built (PRIORSLAM_BIN_DIR)")
    return str(path)


def run_tool(*args, check=True):
    """Runs a built tool; returns the CompletedProcess (text output)."""
    return subprocess.run([tool(args[0]), *map(str, args[1:])], capture_output=True, text=True, check=check)


class Clip:
    """A rendered synthetic sequence: rawlog, ground truth and camera."""

    def __init__(self, folder, name):
        self.folder = pathlib.Path(folder)
        self.rawlog = self.folder / f"{name}.rawlog"
        self.groundtruth = self.folder / f"{name}_groundtruth.txt"
        info = json.loads((self.folder / f"{name}_synth.json").read_text())
        self.camera = info["camera"]


def render(folder, frames, width=640, height=480, seed=0):
    run_tool("slam-synth", "--scenario", "room", "--frames", frames, "--width", width, "--height", height,
             "--seed", seed, "--out", folder, "--quiet")
    return Clip(folder, "room")


@pytest.fixture(scope="session")
def room(tmp_path_factory):
    """60 frames of the room at 640x480: SLAM initializes and tracks (the clip of the e2e comparisons)."""
    return render(tmp_path_factory.mktemp("room"), 60)


@pytest.fixture(scope="session")
def small_room(tmp_path_factory):
    """40 frames of the room at 320x240, for the API's own tests."""
    return render(tmp_path_factory.mktemp("small_room"), 40, 320, 240)
