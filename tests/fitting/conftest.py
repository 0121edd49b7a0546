import pytest
import torch


@pytest.fixture(autouse=True, scope="module")
def _one_thread():
    """The fits run hundreds of small renders: intra-op threads only add synchronisation
    (on a loaded 2-core machine a 12-pixel render took 0.6 s with 2 threads, 4 ms with 1)."""
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)
