"""Built-in scale strategies (docs/method.md, "Strategies")."""
