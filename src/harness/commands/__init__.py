"""The ``swarmsitl`` commands, one module each: what a command's flags mean, nothing more.

Each command turns its flags into a ``SimulationConfig`` (its world through
``harness.sim.world_setup.world_config``) or a scenario, and hands the run to a ``RunSession``
(``harness.run.session``) or a ``ScenarioRun``; ``harness.cli`` assembles them into one typer app.
"""
