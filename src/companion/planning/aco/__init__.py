"""Seed 001's per-UAV ACO path planner on a random roadmap, and an A* baseline (pure)."""
