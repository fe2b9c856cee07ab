"""Server side of the MAVLink mission protocol for missions, geofences and rally points.

Follows PX4's mavlink_mission.cpp (MAVSDK_CONTRACT.md section 7):

* Upload: MISSION_COUNT starts a transfer (count 0 clears the plan; more than the plan holds:
  MAV_MISSION_NO_SPACE; an unknown mission_type: MAV_MISSION_INVALID; another sender's transfer
  in progress: MAV_MISSION_ERROR). The vehicle asks for each item with MISSION_REQUEST_INT,
  re-asks after :data:`RETRY_TIMEOUT_S` of silence (items out of sequence are ignored, so the
  re-request is the answer) and abandons the transfer after :data:`PROTOCOL_TIMEOUT_S` with
  STATUSTEXT "Operation timeout" and no MISSION_ACK. Each item is checked on arrival; a bad one
  aborts with its MAV_MISSION_RESULT. The complete plan is stored and ACKed ACCEPTED; whether a
  mission can be flown is the vehicle's feasibility check, reported afterwards.
* Download: MISSION_REQUEST_LIST -> MISSION_COUNT; MISSION_REQUEST_INT (MISSION_REQUEST) ->
  MISSION_ITEM_INT (MISSION_ITEM); a request past the end -> MAV_MISSION_ERROR.
* MISSION_CLEAR_ALL (type 255 clears all three plans) and MISSION_SET_CURRENT (out of range:
  STATUSTEXT only, as PX4).

Timeouts run on the wall clock, like the command-retransmission window: the peer retries on its
own wall-clock timer, whatever the simulation speed, so a transfer must not expire faster
because the simulation runs faster.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mission.feasibility import ItemRejected, check_fence_plan, check_item
from autopilot_emu.mission.items import MAX_ITEMS, MissionItem, MissionType

logger = logging.getLogger(__name__)

RETRY_TIMEOUT_S = 0.5
"""Silence after which a MISSION_REQUEST_INT is sent again (PX4: 500 ms), wall-clock s."""
PROTOCOL_TIMEOUT_S = 5.0
"""Silence after which an upload is abandoned (PX4: 5 s), wall-clock s."""

Send = Callable[[mavlink2.MAVLink_message], None]
Announce = Callable[[int, str], None]
Peer = tuple[int, int]


class MissionServer(Protocol):
    """What the protocol needs from the vehicle (see VehiclePort)."""

    def mission_items(self, kind: MissionType) -> tuple[MissionItem, ...]:
        """The stored plan of one type."""
        ...

    def upload_mission(self, kind: MissionType, items: tuple[MissionItem, ...]) -> int:
        """Check and store a whole plan; return the MAV_MISSION_RESULT."""
        ...

    def set_mission_current(self, seq: int) -> bool:
        """Make ``seq`` the current mission item; False if it is out of range."""
        ...

    def mission_status(self) -> tuple[int, int, int]:
        """(current seq, total, MISSION_STATE)."""
        ...


def item_from_message(msg: mavlink2.MAVLink_message) -> MissionItem:
    """MISSION_ITEM_INT or MISSION_ITEM -> MissionItem (float lat/lon rounded to degE7)."""
    x, y = msg.x, msg.y
    if msg.get_msgId() == mavlink2.MAVLINK_MSG_ID_MISSION_ITEM:
        x = _degE7(x)
        y = _degE7(y)
    return MissionItem(
        command=msg.command,
        frame=msg.frame,
        params=(msg.param1, msg.param2, msg.param3, msg.param4),
        x=x,
        y=y,
        z=msg.z,
        autocontinue=bool(msg.autocontinue),
    )


def _degE7(value: float) -> int:
    """Degrees as float -> degE7, clamped into int32 (range errors are caught by the checks)."""
    if not math.isfinite(value):
        return 2**31 - 1
    return max(-(2**31), min(2**31 - 1, round(value * 1e7)))


def item_message(
    item: MissionItem, seq: int, kind: MissionType, target: Peer, current: bool, as_int: bool
) -> mavlink2.MAVLink_message:
    """MissionItem -> MISSION_ITEM_INT (or the legacy float MISSION_ITEM) for a download."""
    fields = dict(
        target_system=target[0],
        target_component=target[1],
        seq=seq,
        frame=item.frame,
        command=item.command,
        current=int(current),
        autocontinue=int(item.autocontinue),
        param1=item.params[0],
        param2=item.params[1],
        param3=item.params[2],
        param4=item.params[3],
        z=item.z,
        mission_type=int(kind),
    )
    if as_int:
        return mavlink2.MAVLink_mission_item_int_message(x=item.x, y=item.y, **fields)
    return mavlink2.MAVLink_mission_item_message(x=item.x * 1e-7, y=item.y * 1e-7, **fields)


@dataclass
class _Upload:
    """An upload in progress."""

    partner: Peer
    kind: MissionType
    count: int
    items: list[MissionItem]
    as_int: bool
    """Ask with MISSION_REQUEST_INT (else legacy MISSION_REQUEST, for a partner that sent
    MISSION_ITEM), as PX4 follows what the partner speaks."""
    last_heard_s: float
    last_request_s: float


class MissionProtocol:
    """Answers mission-protocol messages for one vehicle.

    Args:
        vehicle: stores, checks and executes the plans.
        send: sends one message to every peer.
        announce: sends a STATUSTEXT (severity, text).
        wall_clock_s: monotonic clock for transfer timeouts.
    """

    def __init__(
        self,
        vehicle: MissionServer,
        send: Send,
        announce: Announce,
        wall_clock_s: Callable[[], float] = time.monotonic,
    ) -> None:
        self._vehicle = vehicle
        self._send = send
        self._announce = announce
        self._clock = wall_clock_s
        self._upload: _Upload | None = None
        self._finished: _Upload | None = None
        """The last completed upload, to re-ACK a retransmitted final item."""

    @property
    def busy(self) -> bool:
        """True while an upload waits for items (the endpoint then calls :meth:`tick`)."""
        return self._upload is not None

    # --- replies -------------------------------------------------------------------------

    def _ack(self, target: Peer, kind: int, result: int) -> None:
        self._send(
            mavlink2.MAVLink_mission_ack_message(
                target_system=target[0],
                target_component=target[1],
                type=result,
                mission_type=kind & 0xFF,
            )
        )

    def _reject(self, target: Peer, kind: int, result: int, text: str) -> None:
        self._announce(mavlink2.MAV_SEVERITY_CRITICAL, text)
        self._ack(target, kind, result)

    def _request(self, upload: _Upload) -> None:
        seq = len(upload.items)
        cls = (
            mavlink2.MAVLink_mission_request_int_message
            if upload.as_int
            else mavlink2.MAVLink_mission_request_message
        )
        self._send(cls(upload.partner[0], upload.partner[1], seq, int(upload.kind)))
        upload.last_request_s = self._clock()

    @staticmethod
    def _kind(value: int) -> MissionType | None:
        try:
            kind = MissionType(value)
        except ValueError:
            return None
        return None if kind == MissionType.ALL else kind

    # --- upload --------------------------------------------------------------------------

    def handle_count(self, msg: mavlink2.MAVLink_message, partner: Peer) -> None:
        """MISSION_COUNT: start an upload of ``count`` items."""
        kind = self._kind(msg.mission_type)
        if kind is None:
            self._ack(partner, msg.mission_type, mavlink2.MAV_MISSION_INVALID)
            return
        upload = self._upload
        if upload is not None:
            if upload.partner == partner and not upload.items:
                # The first request was lost and the partner sent MISSION_COUNT again.
                upload.kind, upload.count = kind, msg.count
                upload.last_heard_s = self._clock()
                self._request(upload)
                return
            self._reject(partner, kind, mavlink2.MAV_MISSION_ERROR, "WPM: REJ. CMD: Busy")
            return
        if msg.count > MAX_ITEMS[kind]:
            self._reject(
                partner,
                kind,
                mavlink2.MAV_MISSION_NO_SPACE,
                f"Mission upload rejected: {msg.count} items, at most {MAX_ITEMS[kind]}",
            )
            return
        if msg.count == 0:
            self._ack(partner, kind, self._vehicle.upload_mission(kind, ()))
            return
        now = self._clock()
        self._upload = _Upload(partner, kind, msg.count, [], True, now, now)
        self._request(self._upload)

    def handle_item(self, msg: mavlink2.MAVLink_message, partner: Peer) -> None:
        """MISSION_ITEM_INT / MISSION_ITEM during an upload."""
        upload = self._upload
        if upload is None or upload.partner != partner:
            done = self._finished
            if (
                upload is None
                and done is not None
                and done.partner == partner
                and msg.mission_type == done.kind
                and msg.seq == done.count - 1
            ):
                # The final item again: our MISSION_ACK was lost.
                self._ack(partner, done.kind, mavlink2.MAV_MISSION_ACCEPTED)
                return
            self._reject(
                partner,
                msg.mission_type,
                mavlink2.MAV_MISSION_ERROR,
                "IGN MISSION_ITEM: No transfer" if upload is None else "IGN MISSION_ITEM: Busy",
            )
            return
        if msg.mission_type != upload.kind:
            self._ack(partner, msg.mission_type, mavlink2.MAV_MISSION_ERROR)
            return
        upload.last_heard_s = self._clock()
        upload.as_int = msg.get_msgId() == mavlink2.MAVLINK_MSG_ID_MISSION_ITEM_INT
        if msg.seq != len(upload.items):
            return  # out of sequence: ignored, the retry timer asks again
        item = item_from_message(msg)
        try:
            check_item(upload.kind, item, msg.seq)
            upload.items.append(item)
            if len(upload.items) == upload.count and upload.kind == MissionType.FENCE:
                check_fence_plan(tuple(upload.items))
        except ItemRejected as error:
            self._upload = None
            logger.info("mission upload from %s rejected: %s", partner, error.message)
            self._reject(partner, upload.kind, error.result, f"IGN MISSION_ITEM: {error.message}")
            return
        if len(upload.items) < upload.count:
            self._request(upload)
            return
        self._upload = None
        self._finished = upload
        self._ack(
            partner, upload.kind, self._vehicle.upload_mission(upload.kind, tuple(upload.items))
        )

    def tick(self) -> None:
        """Re-request a missing item, or give up on a silent partner."""
        upload = self._upload
        if upload is None:
            return
        now = self._clock()
        if now - upload.last_heard_s > PROTOCOL_TIMEOUT_S:
            self._upload = None
            self._announce(mavlink2.MAV_SEVERITY_CRITICAL, "Operation timeout")
        elif now - upload.last_request_s > RETRY_TIMEOUT_S:
            self._request(upload)

    # --- download ------------------------------------------------------------------------

    def handle_request_list(self, msg: mavlink2.MAVLink_message, partner: Peer) -> None:
        """MISSION_REQUEST_LIST: reply MISSION_COUNT of the stored plan."""
        kind = self._kind(msg.mission_type)
        if kind is None:
            self._ack(partner, msg.mission_type, mavlink2.MAV_MISSION_INVALID)
            return
        if self._upload is not None:
            self._announce(
                mavlink2.MAV_SEVERITY_INFO, "Mission download request ignored, already active"
            )
            return
        count = len(self._vehicle.mission_items(kind))
        self._send(mavlink2.MAVLink_mission_count_message(partner[0], partner[1], count, kind))

    def handle_request(self, msg: mavlink2.MAVLink_message, partner: Peer) -> None:
        """MISSION_REQUEST_INT / MISSION_REQUEST: send that item of the stored plan."""
        kind = self._kind(msg.mission_type)
        if kind is None or self._upload is not None:
            return  # PX4 drops requests of another type, and during an upload
        items = self._vehicle.mission_items(kind)
        if not 0 <= msg.seq < len(items):
            self._reject(
                partner, kind, mavlink2.MAV_MISSION_ERROR, "WPM: REJ. CMD: Req. WP was unexpected"
            )
            return
        as_int = msg.get_msgId() == mavlink2.MAVLINK_MSG_ID_MISSION_REQUEST_INT
        current = (
            msg.seq == self._vehicle.mission_status()[0]
        )  # PX4 flags the mission's current seq, any type
        self._send(item_message(items[msg.seq], msg.seq, kind, partner, current, as_int))

    # --- clear and set current -------------------------------------------------------------

    def handle_clear_all(self, msg: mavlink2.MAVLink_message, partner: Peer) -> None:
        """MISSION_CLEAR_ALL of one plan, or of all three with MAV_MISSION_TYPE_ALL."""
        if msg.mission_type == MissionType.ALL:
            kinds = [MissionType.MISSION, MissionType.FENCE, MissionType.RALLY]
        else:
            kind = self._kind(msg.mission_type)
            if kind is None:
                self._ack(partner, msg.mission_type, mavlink2.MAV_MISSION_INVALID)
                return
            kinds = [kind]
        if self._upload is not None:
            self._announce(mavlink2.MAV_SEVERITY_CRITICAL, "WPM: IGN CLEAR CMD: Busy")
            return
        results = [self._vehicle.upload_mission(kind, ()) for kind in kinds]
        failed = [r for r in results if r != mavlink2.MAV_MISSION_ACCEPTED]
        self._ack(partner, msg.mission_type, failed[0] if failed else results[0])

    def handle_set_current(self, msg: mavlink2.MAVLink_message) -> None:
        """MISSION_SET_CURRENT; out of range: STATUSTEXT only (PX4 sends no MISSION_ACK)."""
        if self._upload is not None:
            self._announce(mavlink2.MAV_SEVERITY_CRITICAL, "WPM: IGN WP CURR CMD: Busy")
        elif not self._vehicle.set_mission_current(msg.seq):
            self._announce(mavlink2.MAV_SEVERITY_CRITICAL, "WPM: WP CURR CMD: Not in list")
