"""LAS/LAZ through laspy: read into a PointCloud, write per-point saliency as extra dimensions.

Written files are LAS 1.4 (the version whose specification defines extra dimensions). A LAS 1.4
input keeps every original point record byte, VLR/EVLR and the CRS; an older input (1.0-1.3) is
converted to the matching 1.4 point format with every dimension's values kept
(:mod:`~lidar_sig.io.las._upgrade`). A COPC input is written as plain LAZ
(:mod:`~lidar_sig.io.las._copc`). The saliency dimensions (docs/method.md, "LAS/LAZ output") are added; those of an
earlier run are replaced, a user's own dimension of the same name never is
(:mod:`~lidar_sig.io.las._dims`).
"""
from ..fields import saliency_fields
from ._lasdata import check_las_output, las_scaling, to_lasdata
from ._dims import SALIENCY_DIMS, is_ours, lidar_sig_dims, set_extra_bytes_ranges
from ._read import LAS_EXTENSIONS, las_xyz, read_las
from ._upgrade import upgrade_to_14
from ._write import write_las, write_las_chunks
from ._copc import drop_copc, without_copc

__all__ = ["LAS_EXTENSIONS", "SALIENCY_DIMS", "check_las_output", "drop_copc", "is_ours", "las_scaling", "las_xyz", "lidar_sig_dims",
           "read_las", "saliency_fields", "set_extra_bytes_ranges", "to_lasdata", "upgrade_to_14", "without_copc", "write_las",
           "write_las_chunks"]
