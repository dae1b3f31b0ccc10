"""The base layer: errors a user can fix, progress, the compilation of the kernels, notebook views."""
