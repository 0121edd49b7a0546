"""Scale-out beside the products: library calls distributed on Dask, no physics here (issue 24).

:func:`build_table` evaluates any broadcasting library function over a grid of named axes in
chunks — in this process, on an embedded ``LocalCluster`` or on any Dask scheduler — into a
resumable Zarr store; :func:`load_table` / :func:`open_table` read it back.
:func:`fit_batch` fits many cubes or scatterograms independently into one result table
(:func:`write_results`: JSON, CSV, Parquet), a bad file reported and the rest finished.
:func:`montecarlo_brdf_blocks` runs the Monte Carlo reference in independent seeded blocks,
bit-identical whatever runs them. Needs the ``scale``
extra (dask, distributed, zarr); not imported by ``import torchirid``.
"""

from .fits import fit_batch, fit_item, write_results
from .montecarlo import block_seeds, merge_moments, montecarlo_brdf_blocks
from .tables import WORKER_ENVIRON, TableBuild, build_table, load_table, local_cluster, open_table, table_chunks

__all__ = ["WORKER_ENVIRON", "TableBuild", "block_seeds", "build_table", "fit_batch", "fit_item", "load_table",
           "local_cluster", "merge_moments", "montecarlo_brdf_blocks", "open_table", "table_chunks", "write_results"]
