"""The docstring examples of the package (and of its plot and fleet modules) run, and every
public function has a docstring that states its units."""

import doctest
import importlib

import pytest

import imunoise
from imunoise import fleet


def test_docstring_examples_run():
    r = doctest.testmod(imunoise, optionflags=doctest.ELLIPSIS)
    assert r.attempted >= 2 and r.failed == 0


# `imunoise.plot` is the function; the module is reached through the import system
@pytest.mark.parametrize("module", ["imunoise.plot", "imunoise.fleet"])
def test_submodule_docstring_examples_run(module):
    r = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert r.attempted >= 2 and r.failed == 0


def test_public_docstrings_state_units():
    for name in ("avar", "fit", "simulate", "theory", "read", "analyze"):
        doc = getattr(imunoise, name).__doc__
        assert doc and "Hz" in doc, name
    assert "Hz" in imunoise.__doc__ and " s" in imunoise.__doc__ and "squared" in imunoise.__doc__
    assert "MAD" in fleet.__doc__
