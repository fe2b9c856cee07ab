"""Companion programs at swarm scale: the same algorithms behind a kinematic vehicle adapter.

A role's module offers ``swarm_program(env, vehicle, node)`` next to its MAVSDK ``main``; the
swarm-scale engine (``fidelity: swarm``, docs/swarm.md) calls it once per vehicle and then the
program's ``decide`` at the scenario's decision rate, in simulation time, in-process.
"""

from companion.swarm.vehicle import Detection, Sensed, SwarmProgram, SwarmVehicle

__all__ = ["Detection", "Sensed", "SwarmProgram", "SwarmVehicle"]
