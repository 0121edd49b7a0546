"""Shared pytest configuration for the torchirid tests."""

import os
import sys

# Make the plain helper module tests/oracles.py importable as `from oracles import ...`
# from test files in any subfolder (tests/optics/, ...), whatever pytest's import mode.
_TESTS_DIR = os.path.dirname(os.path.abspath(__file__))
if _TESTS_DIR not in sys.path:
    sys.path.insert(0, _TESTS_DIR)

# Property tests explore at random during development; CI (CI=true) replays a fixed,
# derandomized set so that a submission's result does not depend on the draw.
from hypothesis import settings as _hyp_settings  # noqa: E402

_hyp_settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
if os.environ.get("CI"):
    _hyp_settings.load_profile("ci")


# Devices for the device-sensitive tests: a test that takes a ``device`` argument runs once per
# available device — the CPU always, CUDA when torch sees it. TORCHIRID_TEST_DEVICES=cpu,cuda:1
# names them explicitly (a named device that is not there fails, it does not skip). MPS is not
# in the default list: it has no float64, which the reference comparisons need.
import torch  # noqa: E402


def available_devices() -> list[str]:
    named = os.environ.get("TORCHIRID_TEST_DEVICES", "").strip()
    if named:
        return [d.strip() for d in named.split(",") if d.strip()]
    return ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])


def pytest_generate_tests(metafunc):
    if "device" in metafunc.fixturenames:
        metafunc.parametrize("device", [torch.device(d) for d in available_devices()], ids=str)
