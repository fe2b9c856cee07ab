"""Sensor models, each vectorised over the fleet; values in SI units and body FRD / NED."""
