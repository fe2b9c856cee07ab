"""Flight control of the fleet: three fused loops, each one state, one entry point, one kernel.

- :mod:`nav` (navigation rate): trajectory smoothing -> position control (``NavLoop.step``);
- :mod:`hover_thrust` (navigation rate): the hover-thrust estimator (``HoverThrustLoop.step``);
- :mod:`inner_loop` (IMU rate): attitude -> body rates -> mixer (``InnerLoop.step``).

The ``*_kernel`` modules hold the compiled per-vehicle rows the loops' kernels are built from;
:mod:`mixer` the allocation from the rotor geometry, :mod:`trajectory` the navigator's queries
of the trajectory law.
"""
