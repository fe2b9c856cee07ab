"""Forwarding between one vehicle's MAVLink links, for the other components of its system.

PX4 starts its SITL links with forwarding on (``mavlink start -f``, px4-rc.mavlink): a message
received on one link that is not addressed to PX4 alone is passed, frame for frame, to every
other link with forwarding on (``Mavlink::forward_message``). That is how a MAVLink camera on
PX4's onboard payload link (compid 100, same system id) is seen by MAVSDK on the offboard link and
by a ground station, and how their commands for compid 100 reach it.

The emulator forwards a received frame, verbatim (same header, sequence number, source ids and
CRC), to the vehicle's other links when

* it comes from another component of the vehicle's own system (a camera's HEARTBEAT, its
  CAMERA_IMAGE_CAPTURED, its COMMAND_ACK to a ground station), unless it is addressed to the
  autopilot itself; or
* it is addressed to another component of the vehicle's system (target_system = ours,
  target_component neither 0 nor ours), e.g. a ground station's command for the camera.

Deviation from PX4: traffic between other systems is not forwarded. PX4's ``-f`` also relays
broadcasts of every system (a ground station's HEARTBEAT reaches MAVSDK, MAVSDK's reaches the
ground station); here the ground stations and SDKs of different links never see each other,
which keeps each client's view of the network what it would be on a direct link to the vehicle.
Broadcasts from other systems (target_component 0) are therefore not forwarded either.
SETUP_SIGNING is never forwarded (the MAVLink signing spec; PX4's ``handle_message``).

On signed links (:mod:`autopilot_emu.mavlink.signing`) a relayed frame keeps its sender's
signature: PX4 resends the received message as it is (``_mavlink_resend_uart``), it does not
re-sign. Only frames a signed link accepted are relayed, so they are signed with the vehicle's
key, except the few PX4 accepts unsigned (RADIO_STATUS, ADSB_VEHICLE, COLLISION), which stay
unsigned. A link without signing relays a signed frame with its signature too.
"""

from __future__ import annotations

from collections.abc import Callable

from pymavlink.dialects.v20 import common as mavlink2

Relay = Callable[[bytes], None]
"""Sends one received frame, unchanged, out of a link (to its peers, and into its tlog)."""


def should_forward(msg: mavlink2.MAVLink_message, sysid: int, compid: int) -> bool:
    """Whether a frame received by the autopilot ``sysid``/``compid`` goes to its other links."""
    if msg.get_msgId() == mavlink2.MAVLINK_MSG_ID_SETUP_SIGNING:
        return False
    src_system = msg.get_srcSystem()
    target_system = getattr(msg, "target_system", 0)
    target_component = getattr(msg, "target_component", 0)
    if src_system == sysid:
        if msg.get_srcComponent() == compid:
            return False  # our own frame, looped back
        return not (target_system == sysid and target_component == compid)
    return target_system == sysid and target_component not in (0, compid)


class ForwardingGroup:
    """The links of one vehicle that forward to each other (PX4's instances with ``-f``)."""

    def __init__(self) -> None:
        self._relays: list[Relay | None] = []

    def join(self, relay: Relay) -> int:
        """A new link: its member id in the group."""
        self._relays.append(relay)
        return len(self._relays) - 1

    def leave(self, member: int) -> None:
        """A link closed: nothing more is forwarded to it."""
        self._relays[member] = None

    def forward(self, origin: int, frame: bytes) -> int:
        """Send ``frame`` out of every member but ``origin``; returns how many links took it."""
        sent = 0
        for member, relay in enumerate(self._relays):
            if member != origin and relay is not None:
                relay(frame)
                sent += 1
        return sent
