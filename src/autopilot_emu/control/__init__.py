"""Flight controllers: position, attitude, rate, and the mixer."""
