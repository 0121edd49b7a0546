"""Scale-out beside the products: library calls distributed on Dask, no physics here.

:func:`build_table` evaluates any broadcasting library function over a grid of named axes in
chunks — in this process, on an embedded ``LocalCluster`` or on any Dask scheduler — into a
resumable Zarr store; :func:`read_table` / :func:`open_table` read it back.
:func:`fit_batch` fits many cubes or scatterograms independently into one result table
(:func:`write_results`: JSON, CSV, Parquet), a bad file reported and the rest finished.
:func:`montecarlo_brdf_blocks` runs the Monte Carlo reference in independent seeded blocks,
bit-identical whatever runs them. Needs the ``scale``
extra (dask, distributed, zarr); not imported by ``import torchirid``.
"""

from .fits import fit_batch, write_results
from .montecarlo import montecarlo_brdf_blocks
from .tables import TableBuild, build_table, read_table, local_cluster, open_table

__all__ = ["TableBuild", "build_table", "fit_batch", "read_table",
           "local_cluster", "montecarlo_brdf_blocks", "open_table", "write_results"]
