"""The simulation and what it is built of: world, autopilots, links, recordings."""
