"""Missions, geofence and rally points: storage, upload checks and execution (PX4 navigator)."""
