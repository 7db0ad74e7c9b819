"""The examples in the package's docstrings run and print what they show."""

import doctest

import pytest

import hookean
import hookean.builders
import hookean.ode
import hookean.sparse


@pytest.mark.parametrize("module", [hookean, hookean.builders, hookean.ode, hookean.sparse])
def test_docstring_examples(module):
    result = doctest.testmod(module, extraglobs={"hookean": hookean})
    assert result.failed == 0
