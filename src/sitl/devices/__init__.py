"""Devices the simulated vehicles carry that talk to the outside world (camera streams, ...)."""
