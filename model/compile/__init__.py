"""model/compile."""
