"""Requests a role makes: one that may time out, and one asked again until answered."""

from __future__ import annotations

from typing import Any

from companion import clock
from companion.net import AsyncNode, RequestTimeout


async def ask(
    node: AsyncNode,
    dst: str,
    topic: str,
    body: Any,
    timeout_s: float,
    retries: int,
    category: str = "control",
) -> bool:
    """Send a request (retried ``retries`` times); whether a reply came."""
    try:
        await node.request(dst, topic, body, timeout_s, retries, category=category)
    except RequestTimeout:
        return False
    return True


async def ask_until_answered(
    node: AsyncNode,
    dst: str,
    topic: str,
    body: Any,
    timeout_s: float,
    retries: int,
    end_s: float,
) -> tuple[bool, int]:
    """Ask again until ``dst`` answers or simulated time ``end_s``: the peer may start later.

    Returns:
        Whether it answered, and how many requests timed out before.
    """
    timeouts = 0
    while clock.now_s() < end_s:
        if await ask(node, dst, topic, body, timeout_s, retries):
            return True, timeouts
        timeouts += 1
    return False, timeouts
