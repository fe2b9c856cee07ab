"""Perception of the companion: camera frames in, detections in the world frame out."""
