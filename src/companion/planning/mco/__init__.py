"""Seed 004 (MCO Plan): world abstraction, area partitioning and the mission's other stages."""
