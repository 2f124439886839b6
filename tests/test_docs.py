"""The manuals' examples run as written."""

import doctest

import pytest

import mobile_envs.catalogue
import mobile_envs.envs.path_following


@pytest.mark.parametrize("module", [mobile_envs.envs.path_following, mobile_envs.catalogue])
def test_docstring_examples_run(module):
    failures, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert tried > 0 and failures == 0
