"""Seed 004's MCO Plan: world abstraction, partitions, roles, auction and tours (pure)."""
