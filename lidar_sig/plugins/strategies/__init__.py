"""Built-in scale strategies (SPEC 4)."""
