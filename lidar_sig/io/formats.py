"""The file extensions of each format (lower case), known without loading any format's module
or library (laspy, h5py, Open3D): the command line checks its output names with them first."""

LAS_EXTENSIONS = (".las", ".laz")
OPEN3D_EXTENSIONS = (".ply", ".pcd")
TEXT_EXTENSIONS = (".xyz", ".txt", ".pts", ".csv")
#: The point clouds :func:`lidar_sig.io.read` reads and :func:`lidar_sig.io.write_cloud` writes.
CLOUD_EXTENSIONS = LAS_EXTENSIONS + OPEN3D_EXTENSIONS + TEXT_EXTENSIONS
#: Signature archives (SPEC 8).
HDF5_EXTENSIONS = (".h5", ".hdf5")
