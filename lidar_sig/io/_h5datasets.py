"""HDF5 files of the project (signature archives, survey catalogues): built in memory and
written whole, and datasets that say what they hold."""
from __future__ import annotations

import contextlib
import io

import numpy as np

from .atomic import atomic_output

#: Compression of datasets above 64 values: gzip level 4 after byte shuffling.
GZIP = {"compression": "gzip", "compression_opts": 4, "shuffle": True}


@contextlib.contextmanager
def hdf5_output(path, file_format, version, *, overwrite=False):
    """Yield an ``h5py.File`` open for writing, its attributes ``format``, ``format_version``
    and ``lidar_sig_version`` set; written to ``path`` as a whole (:func:`atomic_output`) when
    the block ends without error. The file is built in memory and its bytes written by Python:
    a full disk or a signal then stops our write, not one inside the HDF5 library (which may
    crash on a full disk)."""
    import h5py

    from .. import __version__

    buffer = io.BytesIO()
    with atomic_output(path, overwrite=overwrite) as tmp:
        with h5py.File(buffer, "w") as f:
            f.attrs["format"] = file_format
            f.attrs["format_version"] = version
            f.attrs["lidar_sig_version"] = __version__
            yield f
        tmp.write_bytes(buffer.getbuffer())


def described_dataset(group, name, data, description, units=None, *, compress=True):
    """A dataset of ``group`` holding ``data`` (a list: text), with the attributes
    ``description`` and, when given, ``units``; compressed (:data:`GZIP`) above 64 values."""
    import h5py

    if isinstance(data, list):
        ds = group.create_dataset(name, data=np.array(data, dtype=object), dtype=h5py.string_dtype())
    else:
        ds = group.create_dataset(name, data=data, **(GZIP if compress and np.size(data) > 64 else {}))
    ds.attrs["description"] = description
    if units:
        ds.attrs["units"] = units
    return ds
