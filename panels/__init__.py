"""UI panels: draw state, never compute."""
