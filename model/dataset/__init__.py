"""model/dataset."""
