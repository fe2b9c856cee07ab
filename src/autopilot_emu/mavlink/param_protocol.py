"""Server side of the MAVLink parameter protocol (MAVSDK_CONTRACT.md section 9).

PARAM_REQUEST_READ (by name with index -1, or by index), PARAM_REQUEST_LIST (every parameter
with its index and the total count, a batch per poll) and PARAM_SET (bytewise-decoded, type and
range checked, answered by a PARAM_VALUE echo of the stored value). Failures are answered with
PARAM_ERROR carrying the MAV_PARAM_ERROR code, where PX4 would stay silent and leave the client to
time out.
"""

from __future__ import annotations

from collections.abc import Callable

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.params import (
    PARAM_ERROR_TYPE_MISMATCH,
    ParamError,
    ParamStore,
    decode_param_value,
    encode_param_value,
)

LIST_BATCH_SIZE = 32
"""PARAM_VALUE messages sent per poll while answering PARAM_REQUEST_LIST."""

Send = Callable[[mavlink2.MAVLink_message], None]


def _param_id_bytes(name: str) -> bytes:
    """Name -> the 16-byte param_id field (pymavlink pads with NUL)."""
    return name.encode("ascii", errors="replace")[:16]


class ParamProtocol:
    """Answers parameter messages for one :class:`ParamStore`.

    Args:
        params: the vehicle's parameters.
        send: sends one message to every peer.
    """

    def __init__(self, params: ParamStore, send: Send) -> None:
        self._params = params
        self._send = send
        self._next_list_index: int | None = None

    @property
    def list_pending(self) -> bool:
        """True while a PARAM_REQUEST_LIST answer is still being sent."""
        return self._next_list_index is not None

    def value_message(self, name: str) -> mavlink2.MAVLink_message:
        """PARAM_VALUE for ``name`` with its current value, type, index and the count."""
        params = self._params
        mav_type = params.type_of(name)
        return mavlink2.MAVLink_param_value_message(
            param_id=_param_id_bytes(name),
            param_value=encode_param_value(params.get(name), mav_type),
            param_type=mav_type,
            param_count=params.count,
            param_index=params.index_of(name),
        )

    def _error(self, source: tuple[int, int], name: str, index: int, error: ParamError) -> None:
        self._send(
            mavlink2.MAVLink_param_error_message(
                target_system=source[0],
                target_component=source[1],
                param_id=_param_id_bytes(name),
                param_index=index,
                error=error.code,
            )
        )

    def handle_request_list(self) -> None:
        """PARAM_REQUEST_LIST: (re)start streaming every parameter from index 0."""
        self._next_list_index = 0

    def send_list_batch(self) -> None:
        """Send the next :data:`LIST_BATCH_SIZE` parameters of a pending list request."""
        start = self._next_list_index
        if start is None:
            return
        names = self._params.names
        stop = min(len(names), start + LIST_BATCH_SIZE)
        self._next_list_index = stop if stop < len(names) else None
        for name in names[start:stop]:
            self._send(self.value_message(name))

    def handle_request_read(self, msg: mavlink2.MAVLink_message) -> None:
        """PARAM_REQUEST_READ: by name when param_index is -1, else by index."""
        source = (msg.get_srcSystem(), msg.get_srcComponent())
        index = msg.param_index
        name = msg.param_id
        try:
            if index >= 0:
                name = self._params.name_at(index)
            self._send(self.value_message(name))
        except ParamError as error:
            self._error(source, name, index, error)

    def handle_set(self, msg: mavlink2.MAVLink_message) -> None:
        """PARAM_SET: decode bytewise, validate, store, echo the stored value as PARAM_VALUE."""
        source = (msg.get_srcSystem(), msg.get_srcComponent())
        name = msg.param_id
        try:
            stored_type = self._params.type_of(name)
            if msg.param_type != stored_type:
                raise ParamError(
                    PARAM_ERROR_TYPE_MISMATCH,
                    f"{name} has MAV_PARAM_TYPE {stored_type}, PARAM_SET sent {msg.param_type}",
                )
            self._params.set_from_client(name, decode_param_value(msg.param_value, stored_type))
        except ParamError as error:
            self._error(source, name, -1, error)
            return
        self._send(self.value_message(name))
