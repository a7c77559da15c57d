"""Paths the suite needs. ctest sets them (KATA_LIBRARY, KATA_CLI, KATA_WRONG_VERSION_LIBRARY); run
by hand from a checkout with a build in <repo>/build they default to that build. With
KATA_TEST_INSTALLED=1 (bindings/tests/wheel_test.py) the suite tests the installed package: the
source package is not put on sys.path."""
import os
import sys

import pytest

REPO = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", ".."))
INSTALLED = os.environ.get("KATA_TEST_INSTALLED") == "1"
if not INSTALLED:
    sys.path.insert(0, os.path.join(REPO, "bindings", "python"))


@pytest.fixture(scope="session")
def repo():
    return REPO


@pytest.fixture(scope="session")
def cli():
    path = os.environ.get("KATA_CLI", os.path.join(REPO, "build", "bin", "kata"))
    if not os.path.exists(path):
        pytest.fail("the kata CLI is needed (set KATA_CLI): " + path)
    return path


@pytest.fixture(scope="session")
def data(repo):
    return os.path.join(repo, "data", "cmu")


@pytest.fixture(scope="session")
def model_path(repo):
    return os.path.join(repo, "models", "default.kata")
