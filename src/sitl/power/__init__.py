"""Electrical power of the simulated vehicles: LiPo pack, propulsion power, payload loads.

- :mod:`sitl.power.battery`: LiPo pack (open-circuit voltage vs state of charge, internal
  resistance, sag under load, capacity), integrated in simulation time;
- :mod:`sitl.power.propulsion`: electrical power of the rotors from thrust (momentum theory with a
  figure of merit and a motor + ESC efficiency) and the voltage-limited rotor speed;
- :mod:`sitl.power.loads`: avionics and payload loads (seed 000, Table I presets);
- :mod:`sitl.power.system`: the fleet's power system as the World advances it;
- :mod:`sitl.power.energy`: energy ledger per node, component and task (seed 000, Table I).
"""
