"""Fixtures: a goniod on the mock shared by a module's tests, and a fresh one for the tests
that stop it."""
import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))
from goniod_process import Goniod  # noqa: E402


@pytest.fixture(scope="module")
def goniod():
    d = Goniod()
    yield d
    d.close()


@pytest.fixture
def own_goniod():
    d = Goniod()
    yield d
    d.close()
