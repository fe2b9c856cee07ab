"""Path planners of the companion: pure geometry in, waypoints out."""
