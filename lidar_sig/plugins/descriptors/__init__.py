"""Built-in local geometric descriptors (SPEC 3)."""
