"""MAVLink 2 framing of pymavlink message objects, without pymavlink's per-frame objects.

pymavlink's ``MAVLink_message.pack`` builds a header object, a CRC object and several
intermediate byte arrays for every frame; at PX4's onboard rates (about 400 frames per second per
vehicle) that is a large share of the endpoint's cost. :func:`encode` produces the same bytes
(unsigned MAVLink 2: header, payload with trailing zeros removed, CRC-16/MCRF4XX over header and
payload plus the message's CRC extra) from the message's own field values and payload ``Struct``,
read with one precomputed ``attrgetter`` per message class. :func:`encode_fields` frames the
hot streams' field values directly (:data:`autopilot_emu.mavlink.messages.FIELDS`), without a
pymavlink object at all.

Compat flags are always 0. Incompat flags are 0, or 0x01 on a signed link: the flag is covered by
the CRC, so it is set here and :mod:`autopilot_emu.mavlink.signing` appends the signature.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass
from operator import attrgetter

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.generator import mavcrc

_HEADER = struct.Struct("<BBBBBBBHB")
"""magic, payload length, incompat flags, compat flags, seq, sysid, compid, msgid (24 bit)."""
_MAGIC_V2 = 0xFD
_MAGIC_V1 = 0xFE
_BODY_HEADER = struct.Struct("<BBBBBBHB")
"""The header after the magic byte: what the CRC covers, with the payload."""
_MAGIC_V2_BYTE = bytes((_MAGIC_V2,))


def _crc_python(data: bytes, crc: int) -> int:
    """CRC-16/MCRF4XX of ``data`` carried on from ``crc`` (pymavlink's pure-Python CRC)."""
    state = mavcrc.x25crc()
    state.crc = crc
    state.accumulate(data)
    return state.crc


_crc_from: Callable[[bytes, int], int] = mavcrc.mcrf4xx or _crc_python
"""CRC-16/MCRF4XX of some bytes carried on from a CRC (0xFFFF to start): pymavlink's fastcrc
binding when installed. The CRC has no final XOR, so chaining equals one pass over both."""
_CRC = struct.Struct("<H")


@dataclass(frozen=True)
class _Plan:
    """How to frame one pymavlink message class."""

    values: Callable[[object], tuple]
    """The field values in wire order (char arrays as their raw bytes)."""
    arrays: tuple[bool, ...]
    """Per value: an array (list, tuple or bytes) that the payload struct takes element by
    element; empty when the message has no such field."""
    payload: struct.Struct
    crc_extra: bytes
    msg_id_low: int
    msg_id_high: int


_plans: dict[type, _Plan] = {}


def _plan(cls: type) -> _Plan:
    """The framing plan of a pymavlink message class (built once per class).

    ``array_lengths`` follows the wire order; a char array packs as one ``bytes`` value, kept
    by pymavlink in ``_<name>_raw`` (the public attribute is the decoded text).
    """
    plan = _plans.get(cls)
    if plan is None:
        types = dict(zip(cls.fieldnames, cls.fieldtypes, strict=True))
        names, arrays = [], []
        for name, length in zip(cls.ordered_fieldnames, cls.array_lengths, strict=True):
            is_char = types[name] == "char"
            names.append(f"_{name}_raw" if is_char else name)
            arrays.append(length > 0 and not is_char)
        getter = attrgetter(*names)
        values = getter if len(names) > 1 else (lambda message: (getter(message),))
        plan = _Plan(
            values=values,
            arrays=tuple(arrays) if any(arrays) else (),
            payload=cls.unpacker,
            crc_extra=bytes((cls.crc_extra,)),
            msg_id_low=cls.id & 0xFFFF,
            msg_id_high=cls.id >> 16,
        )
        _plans[cls] = plan
    return plan


def encode(
    message: mavlink2.MAVLink_message, seq: int, sysid: int, compid: int, incompat_flags: int = 0
) -> bytes:
    """The MAVLink 2 frame of ``message``, byte for byte what pymavlink would send.

    ``incompat_flags`` 0x01 marks a frame that will be signed (the signature is not added here).

    Raises:
        struct.error: a field does not fit its wire type (as pymavlink's ``pack``).
    """
    plan = _plan(type(message))
    values = plan.values(message)
    if plan.arrays:
        flat: list[object] = []
        for value, is_array in zip(values, plan.arrays, strict=True):
            if is_array:
                flat.extend(value)
            else:
                flat.append(value)
        values = flat
    payload = plan.payload.pack(*values)
    payload = payload.rstrip(b"\x00") or payload[:1]  # MAVLink 2 truncation, >= 1 byte
    header = _HEADER.pack(
        _MAGIC_V2,
        len(payload),
        incompat_flags,
        0,
        seq,
        sysid,
        compid,
        plan.msg_id_low,
        plan.msg_id_high,
    )
    body = header[1:] + payload
    return header[:1] + body + _CRC.pack(_crc_from(plan.crc_extra, _crc_from(body, 0xFFFF)))


@dataclass(frozen=True)
class FieldsFormat:
    """How to frame one message from its wire-order field values (see :func:`encode_fields`)."""

    payload: struct.Struct
    """The message's payload layout (pymavlink's, extensions included)."""
    crc_extra: bytes
    """The message's CRC extra byte (pymavlink's ``crc_extra``)."""
    msg_id_low: int
    msg_id_high: int
    field_count: int
    """Values the payload takes (array fields element by element)."""


def fields_format(msg_id: int) -> FieldsFormat:
    """The :class:`FieldsFormat` of message ``msg_id`` of the common dialect.

    Raises:
        KeyError: ``msg_id`` is not a message of the dialect.
    """
    cls = mavlink2.mavlink_map[msg_id]
    return FieldsFormat(
        payload=cls.unpacker,
        crc_extra=bytes((cls.crc_extra,)),
        msg_id_low=msg_id & 0xFFFF,
        msg_id_high=msg_id >> 16,
        field_count=sum(max(1, length) for length in cls.array_lengths),
    )


def encode_fields(
    fmt: FieldsFormat, values: tuple, seq: int, sysid: int, compid: int, incompat_flags: int = 0
) -> bytes:
    """The MAVLink 2 frame of a message given as wire-order field values.

    Byte for byte what pymavlink sends for the message object with these values: payload with
    trailing zeros removed (at least one byte kept), CRC-16/MCRF4XX over the header after the
    magic byte and the payload, then the CRC extra (the CRC carried on from the body's, so the
    body is not copied once more). ``incompat_flags`` as in :func:`encode`.

    Raises:
        struct.error: a value does not fit its wire type, or the count is wrong.
    """
    payload = fmt.payload.pack(*values).rstrip(b"\x00") or b"\x00"  # MAVLink 2 truncation
    body = (
        _BODY_HEADER.pack(
            len(payload), incompat_flags, 0, seq, sysid, compid, fmt.msg_id_low, fmt.msg_id_high
        )
        + payload
    )
    return _MAGIC_V2_BYTE + body + _CRC.pack(_crc_from(fmt.crc_extra, _crc_from(body, 0xFFFF)))


def source_and_msgid(frame: bytes | bytearray) -> tuple[int, int, int] | None:
    """(system id, component id, message id) from a MAVLink 1 or 2 frame's header.

    None when ``frame`` is too short or does not start with a MAVLink magic byte.
    """
    if len(frame) >= 10 and frame[0] == _MAGIC_V2:
        return frame[5], frame[6], frame[7] | frame[8] << 8 | frame[9] << 16
    if len(frame) >= 6 and frame[0] == _MAGIC_V1:
        return frame[3], frame[4], frame[5]
    return None
