"""Runnable companion programs (MAVSDK / pymavlink clients)."""
