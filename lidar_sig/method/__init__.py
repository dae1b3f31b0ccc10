"""The method's objects (docs/method.md): point clouds, scales, class tables and class maps, the saliency map, signatures, CRS and units."""
