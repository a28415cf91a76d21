"""The project's two metadata files agree with the lines it supports: pyproject.toml's Python
range admits the interpreter of the line running the tests (3.13 for 5.2, 3.11 for the others;
each line's run checks its own), and its version is the extension's."""

import sys
import tomllib
from pathlib import Path

import pytest
from packaging.specifiers import SpecifierSet

pytestmark = pytest.mark.tier("numpy")

ROOT = Path(__file__).resolve().parents[1]


def _toml(name):
    return tomllib.loads((ROOT / name).read_text(encoding="utf-8"))


def test_pyproject_admits_this_lines_python():
    wanted = SpecifierSet(_toml("pyproject.toml")["project"]["requires-python"])
    running = f"{sys.version_info.major}.{sys.version_info.minor}.{sys.version_info.micro}"
    assert running in wanted, f"pyproject.toml requires-python {wanted} refuses Python {running}"


def test_pyproject_version_is_the_extensions():
    assert _toml("pyproject.toml")["project"]["version"] == _toml("blender_manifest.toml")["version"]
