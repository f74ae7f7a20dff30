"""model/infer."""
