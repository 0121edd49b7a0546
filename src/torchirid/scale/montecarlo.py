r"""Monte Carlo references on Dask: independent seeded blocks, merged in a fixed order.

:func:`montecarlo_brdf_blocks` splits the ``samples`` paths per direction pair of
:func:`torchirid.layered.montecarlo_brdf` into ``blocks`` blocks. Block ``b`` runs
``montecarlo_brdf`` with its own seed, drawn from ``numpy.random.SeedSequence(seed).spawn(blocks)``
(independent streams, fixed by ``seed`` and ``b`` alone), anywhere: in this process, on a
``local_cluster`` or a Dask scheduler. The blocks' (count, mean, M2) are merged on the caller in
block order by Chan et al.'s pairwise update, in a balanced tree — the same operations in the
same order whatever ran where — so the estimate and its standard error are bit-identical for the
same ``seed`` and ``blocks`` with any number of workers, and the merge has no cancellation
(``M2`` is a sum of non-negative terms).
"""

from __future__ import annotations

import numpy as np
import torch

from ..layered import montecarlo_brdf

__all__ = ["montecarlo_brdf_blocks"]


def block_seeds(seed: int, blocks: int) -> list[int]:
    """The seed of every block: ``SeedSequence(seed).spawn(blocks)``, one 63-bit int each.

    Example (distinct seeds; a block's seed does not depend on how many blocks follow it):
        >>> seeds = block_seeds(0, 4)
        >>> len(set(seeds)), all(0 <= s < 2 ** 63 for s in seeds), block_seeds(0, 2) == seeds[:2]
        (4, True, True)
    """
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be an int >= 0; got {seed!r}")
    if isinstance(blocks, bool) or not isinstance(blocks, int) or blocks < 1:
        raise ValueError(f"blocks must be an int >= 1; got {blocks!r}")
    return [int(s.generate_state(2, np.uint64)[0] >> np.uint64(1)) for s in np.random.SeedSequence(seed).spawn(blocks)]


def merge_moments(parts):
    """Merge ``[(count, mean, m2), …]`` (float64 tensors) in a balanced tree, in order (Chan et al.).

    ``m2`` is the sum of squared deviations from the part's mean; the result is the
    ``(count, mean, m2)`` of all the parts together (variance ``m2 / (count − 1)``).

    Example (0, 1, …, 9 in parts of 3, 3, 3 and 1 values):
        >>> import torch
        >>> x = torch.arange(10, dtype=torch.float64)
        >>> parts = [(float(p.numel()), p.mean(), ((p - p.mean()) ** 2).sum()) for p in x.split(3)]
        >>> n, mean, m2 = merge_moments(parts)
        >>> n, float(mean), round(float(m2 / (n - 1)), 6), round(float(x.var()), 6)
        (10.0, 4.5, 9.166667, 9.166667)
    """
    parts = list(parts)
    while len(parts) > 1:
        merged = []
        for a, b in zip(parts[0::2], parts[1::2]):
            (na, ma, sa), (nb, mb, sb) = a, b
            n = na + nb
            delta = mb - ma
            merged.append((n, ma + delta * (nb / n), sa + sb + delta * delta * (na * nb / n)))
        if len(parts) % 2:
            merged.append(parts[-1])
        parts = merged
    return parts[0]


def _block(wavelength, wi, wo, structure, samples, seed, options):
    mean, err = montecarlo_brdf(wavelength, wi, wo, structure, samples=samples, seed=seed, **options)
    mean, err = mean.to(torch.float64), err.to(torch.float64)
    m2 = err * err * ((samples - 1) * samples)  # stderr = sqrt(m2 / ((n - 1) n))
    return float(samples), mean, m2


def montecarlo_brdf_blocks(wavelength, wi, wo, structure, *, samples: int = 1024, blocks: int = 8, seed: int = 0,
                           client=None, scheduler: str | None = None, workers: int = 2, progress=None,
                           timeout: float = 10.0, **options):
    r"""``montecarlo_brdf`` in ``blocks`` independent seeded blocks, anywhere, merged exactly.

    Args:
        wavelength, wi, wo, structure, options: as :func:`torchirid.layered.montecarlo_brdf`
            (``options``: ``single_reflection``, ``transmission``, ``max_depth``, …).
        samples: paths per direction pair in all (≥ 2 per block; split as evenly as possible,
            the first blocks taking one more).
        blocks: independent blocks (the unit of work; fixes the result with ``seed``).
        seed: the seed of the whole estimate (``block_seeds()``).
        client, scheduler, workers, timeout: where the blocks run, as
            :func:`torchirid.scale.build_table` (default: this process).
        progress: ``None`` or a callable ``progress(done, total)``: blocks finished out of
            ``blocks``, as they finish.

    Returns:
        ``(mean, stderr)`` of shape ``(*, W)``, float64: bit-identical for the same ``seed`` and
        ``blocks`` whatever runs the blocks.

    Example:
        >>> import torch
        >>> from torchirid.layered import LayeredBragg, RoughBraggLayer
        >>> s = LayeredBragg([RoughBraggLayer(1.0, 1.5, 100.0, 100.0, 5, 0.2)], base_albedo=0.5)
        >>> w = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
        >>> lam = torch.tensor([500.0], dtype=torch.float64)
        >>> f, err = montecarlo_brdf_blocks(lam, w, w, s, samples=64, blocks=4, transmission="microfacet")
        >>> f.shape, bool(err.item() > 0)
        (torch.Size([1]), True)
    """
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be None or a callable progress(done, total); got {progress!r}")
    seeds = block_seeds(seed, blocks)
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 2 * blocks:
        raise ValueError(f"samples must be an int >= 2 * blocks ({2 * blocks}: two paths per block); got {samples!r}")
    sizes = [samples // blocks + (1 if b < samples % blocks else 0) for b in range(blocks)]
    args = [(wavelength, wi, wo, structure, n, s, options) for n, s in zip(sizes, seeds)]
    if client is None and scheduler is None:
        parts = []
        for b, a in enumerate(args):
            parts.append(_block(*a))
            if progress is not None:
                progress(b + 1, blocks)
    else:
        parts = _distributed(args, client, scheduler, workers, timeout, progress, blocks)
    n, mean, m2 = merge_moments(parts)
    return mean, torch.sqrt(m2 / ((n - 1) * n))


def _distributed(args, client, scheduler, workers, timeout, progress, blocks):
    from distributed import as_completed

    from .tables import _connected

    with _connected(client, scheduler, workers, timeout) as client:
        futures = [client.submit(_block, *a, pure=False) for a in args]
        done = 0
        for _ in as_completed(futures):
            done += 1
            if progress is not None:
                progress(done, blocks)
        return [f.result() for f in futures]  # in block order: the merge does not depend on timing
