"""Running a simulation with processes around it: lifecycle, lockstep, clock, ports."""
