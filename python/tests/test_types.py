"""The type stubs say what the native module has, and the package type-checks."""

import subprocess
import sys

import pytest


def mypy(*args):
    pytest.importorskip("mypy")
    return subprocess.run([sys.executable, "-m", *args], capture_output=True, text=True, cwd="/")


def test_the_native_stubs_match_the_module():
    p = mypy("mypy.stubtest", "agvsim._native")
    assert p.returncode == 0, p.stdout + p.stderr


def test_the_package_type_checks():
    p = mypy("mypy", "-p", "agvsim", "--no-incremental")
    assert p.returncode == 0, p.stdout + p.stderr
