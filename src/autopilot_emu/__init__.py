"""autopilot_emu package."""
