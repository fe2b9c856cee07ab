"""Edge, fog and cloud roles of seed 000's edge-fog-cloud system, as companion programs.

Each role is an asyncio program on :class:`companion.net.AsyncNode`; ``python -m companion.roles``
runs the role of ``SWARMSITL_NODE`` (docs/messaging.md, "The roles").
"""
