"""Work beyond one process: Dask task graphs for batch fitting, out-of-core photometric stereo
and data-set rendering.

Everything here runs on a :class:`dask.distributed.Client`: a
:class:`~dask.distributed.LocalCluster` of worker processes on this machine by default, or
any running cluster given by its scheduler's address (``dask scheduler`` on one machine,
``dask worker ADDRESS`` on the others, or a deployment such as dask-jobqueue or
dask-kubernetes). Nothing here schedules, retries or
moves data by itself: Dask does, and a task whose worker dies is run again elsewhere.

Modules: :mod:`~brdfkit.distributed.cluster` (the client), :mod:`~brdfkit.distributed.batch`
(many measured files × many models), :mod:`~brdfkit.distributed.tiled` (photometric stereo and
normal integration tile by tile on a Zarr image stack), :mod:`~brdfkit.distributed.synth`
(photometric-stereo data sets, one task per set).

Needs the ``dask`` extra: ``pip install "brdfkit[dask]"``.

References
----------
.. [1] M. Rocklin, "Dask: parallel computation with blocked algorithms and task scheduling",
   Proc. 14th Python in Science Conference (SciPy), 2015.
"""
