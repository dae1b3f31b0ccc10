"""Scale-out: a set of points cut into processing tiles with halos, run on local processes or a
Dask cluster; per-tile results equal the single-block run's (see :mod:`lidar_sig.tiling._core`)."""
