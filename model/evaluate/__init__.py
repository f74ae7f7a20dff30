"""model/evaluate."""
