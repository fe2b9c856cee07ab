"""The kinematic swarm engine: large fleets without physics or autopilots."""
