"""MAVLink 2 framing of pymavlink message objects, without pymavlink's per-frame objects.

pymavlink's ``MAVLink_message.pack`` builds a header object, a CRC object and several
intermediate byte arrays for every frame; at PX4's onboard rates (about 400 frames per second per
vehicle) that is a large share of the endpoint's cost. :func:`encode` produces the same bytes
(unsigned MAVLink 2: header, payload with trailing zeros removed, CRC-16/MCRF4XX over header and
payload plus the message's CRC extra) from the message's own field values and payload ``Struct``,
with one precomputed field plan per message class.
"""

from __future__ import annotations

import struct

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.generator.mavcrc import x25crc

_HEADER = struct.Struct("<BBBBBBBHB")
"""magic, payload length, incompat flags, compat flags, seq, sysid, compid, msgid (24 bit)."""

_plans: dict[type, tuple[tuple[str, int], ...]] = {}


def _plan(cls: type) -> tuple[tuple[str, int], ...]:
    """(field name, array length or 0) in wire order for a pymavlink message class.

    ``array_lengths`` follows the wire order; a char array packs as one ``bytes`` value, kept
    by pymavlink in ``_<name>_raw`` (the public attribute is the decoded text).
    """
    plan = _plans.get(cls)
    if plan is None:
        types = dict(zip(cls.fieldnames, cls.fieldtypes, strict=True))
        plan = tuple(
            (f"_{name}_raw", 0) if types[name] == "char" else (name, length)
            for name, length in zip(cls.ordered_fieldnames, cls.array_lengths, strict=True)
        )
        _plans[cls] = plan
    return plan


def encode(message: mavlink2.MAVLink_message, seq: int, sysid: int, compid: int) -> bytes:
    """The MAVLink 2 frame of ``message`` (unsigned), byte for byte what pymavlink would send.

    Raises:
        struct.error: a field does not fit its wire type (as pymavlink's ``pack``).
    """
    cls = type(message)
    values: list[object] = []
    for name, length in _plan(cls):
        value = getattr(message, name)
        if length:
            values.extend(value)
        else:
            values.append(value)
    payload = cls.unpacker.pack(*values)
    end = len(payload)
    while end > 1 and payload[end - 1] == 0:
        end -= 1
    payload = payload[:end]
    msg_id = cls.id
    header = _HEADER.pack(0xFD, end, 0, 0, seq, sysid, compid, msg_id & 0xFFFF, msg_id >> 16)
    crc = x25crc(header[1:] + payload)
    crc.accumulate(bytes((cls.crc_extra,)))
    return header + payload + crc.crc.to_bytes(2, "little")
