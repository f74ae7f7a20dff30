"""model/learn."""
