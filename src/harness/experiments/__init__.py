"""The seed papers reproduced: one experiment per seed on the sweep machinery (docs/seedNNN.md)."""
