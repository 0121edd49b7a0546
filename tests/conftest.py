"""Shared pytest configuration for the torchirid tests."""

import os
import sys

# Make the plain helper module tests/oracles.py importable as `from oracles import ...`
# from test files in any subfolder (tests/optics/, ...), whatever pytest's import mode.
_TESTS_DIR = os.path.dirname(os.path.abspath(__file__))
if _TESTS_DIR not in sys.path:
    sys.path.insert(0, _TESTS_DIR)
