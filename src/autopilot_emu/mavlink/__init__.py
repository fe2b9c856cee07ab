"""MAVLink endpoint of the emulated autopilot."""
