"""Built-in local geometric descriptors (docs/method.md, "C3DCM", and docs/descriptors.md)."""
