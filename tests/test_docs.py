"""The manuals' examples run as written."""

import doctest

import pytest

import mobile_envs.env


@pytest.mark.parametrize("module", [mobile_envs.env])
def test_docstring_examples_run(module):
    failures, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert tried > 0 and failures == 0
