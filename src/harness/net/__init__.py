"""The node messaging network of a run: its plan, its role processes, its report.

``plan``: nodes, ports and the router of ``swarmsitl up --net`` / ``net-demo`` / a scenario's
network; ``roles``: the ``companion.roles`` processes and the report they share; ``report``: link
and energy metrics computed from the recordings.
"""
