"""Node messaging for companion programs: msgpack datagrams over UDP or the harness's links.

See docs/messaging.md. The usual entry point is ``AsyncNode.from_env()``.
"""

from companion.net.aio import AsyncNode
from companion.net.config import NetConfig, NetConfigError, NodeSpec, link_class
from companion.net.envelope import (
    MAX_DATAGRAM_BYTES,
    Envelope,
    EnvelopeError,
    MessageTooLargeError,
    decode,
    encode,
)
from companion.net.node import Node, PendingRequest, RequestTimeout
from companion.net.stats import NodeStats
from companion.net.transport import DatagramPort, PortTransport, Transport, UdpTransport

__all__ = [
    "MAX_DATAGRAM_BYTES",
    "AsyncNode",
    "DatagramPort",
    "Envelope",
    "EnvelopeError",
    "MessageTooLargeError",
    "NetConfig",
    "NetConfigError",
    "Node",
    "NodeSpec",
    "NodeStats",
    "PendingRequest",
    "PortTransport",
    "RequestTimeout",
    "Transport",
    "UdpTransport",
    "decode",
    "encode",
    "link_class",
]
