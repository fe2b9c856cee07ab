"""Physics of the simulated world: the PyBullet scene, rotors, and the Earth models."""
