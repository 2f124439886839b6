"""The slow marks of tests/conftest.py name tests that exist, so a renamed test does not slip
into the quick suite (``python -m pytest -m "not slow"``) unnoticed."""

import ast
from pathlib import Path

import pytest
from conftest import SLOW_MODULES, SLOW_TESTS

TESTS = Path(__file__).resolve().parent


def functions_of(module: str) -> set[str]:
    tree = ast.parse((TESTS / module).read_text())
    return {
        node.name
        for node in ast.walk(tree)
        if isinstance(node, ast.FunctionDef) and node.name.startswith("test_")
    }


@pytest.mark.parametrize("module", sorted(SLOW_MODULES | set(SLOW_TESTS)))
def test_every_slow_mark_names_a_test_that_exists(module):
    assert (TESTS / module).is_file()
    assert SLOW_TESTS.get(module, frozenset()) <= functions_of(module)
