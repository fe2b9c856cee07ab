"""Forwarding between one vehicle's MAVLink links, as PX4's ``mavlink start -f`` does.

PX4 starts its SITL links with forwarding on (``mavlink start -f``, px4-rc.mavlink): a message
received on one link that is not addressed to PX4 alone is passed, frame for frame, to every
other link with forwarding on (``Mavlink::forward_message``). That is how a MAVLink camera on
PX4's onboard payload link (compid 100, same system id) is seen by MAVSDK on the offboard link and
by a ground station, and how their commands for compid 100 reach it.

The emulator forwards a received frame, verbatim (same header, sequence number, source ids and
CRC), to the vehicle's other links with forwarding on, never back to the link it came from,
unless it is addressed to the autopilot alone (target system and component both ours) or is the
autopilot's own frame looped back. Where it goes:

* frames of the vehicle's own system (a camera's HEARTBEAT, its CAMERA_IMAGE_CAPTURED, its
  COMMAND_ACK to a ground station) and frames addressed to another component of it (a ground
  station's command for the camera): to every other link;
* everything else (other systems' traffic: a ground station's HEARTBEAT, a companion's
  messages for the ground station, broadcasts): as PX4 does, only to the links that have
  heard from the target (``MavlinkReceiver::component_was_seen``): for target system 0 (a
  broadcast, or a message without target fields) a link that has heard from anyone, else one
  that has heard from that system (and from that component, unless it is 0). HEARTBEATs are
  forwarded (PX4's MAV_HB_FORW_EN, default on).

So a GCS on 14550, MAVSDK on 14540, a script on an extra ``--udp-out`` link and a program on the
serial port see each other's heartbeats and can address each other, as through a real PX4.

Deviation from PX4: the vehicle's own components' traffic goes to every link without the
"heard from" check (PX4 forwards a frame for the camera only to a link the camera was heard on,
and the camera's broadcasts only to links that heard from someone), so a listen-only client
sees the camera at once.

Second deviation, on ordering: a relayed HEARTBEAT of another component of the vehicle (the
camera's) waits on each link for that link's next own frame and goes right after it (at most
one HEARTBEAT period). mavsdk_server 4.0 (``ConnectionInitiator``) looks for an autopilot only
when a system first becomes connected, i.e. on its first HEARTBEAT from any component; if a
client starts listening just before a camera HEARTBEAT and after the autopilot's last frame, it
waits for an autopilot forever. On PX4 the autopilot's streams make that window tiny; here, while
a lockstep run holds the simulation, the autopilot is silent but relayed frames still flow.

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


def message_target(msg: mavlink2.MAVLink_message) -> tuple[int, int]:
    """(target_system, target_component) of a message; 0 for fields it does not have."""
    return getattr(msg, "target_system", 0), getattr(msg, "target_component", 0)


def addressed_to(target_system: int, target_component: int, sysid: int, compid: int) -> bool:
    """Whether a message with these target fields is for component ``sysid``/``compid``.

    0 in a target field addresses every system or component.
    """
    return target_system in (0, sysid) and target_component in (0, compid)


def should_forward(msg: mavlink2.MAVLink_message, sysid: int, compid: int) -> bool:
    """Whether a frame received by the autopilot ``sysid``/``compid`` goes to its other links."""
    if msg.get_msgId() == mavlink2.MAVLINK_MSG_ID_SETUP_SIGNING:
        return False
    if msg.get_srcSystem() == sysid and msg.get_srcComponent() == compid:
        return False  # our own frame, looped back
    return message_target(msg) != (sysid, compid)


def required_target(msg: mavlink2.MAVLink_message, sysid: int) -> tuple[int, int] | None:
    """What a link must have heard from to be forwarded ``msg`` (None: every link gets it).

    Frames of our own system and frames for its components go to every link; anything else
    only to links that have heard from its target (PX4's component_was_seen).
    """
    target = message_target(msg)
    if msg.get_srcSystem() == sysid or target[0] == sysid:
        return None
    return target


class ForwardingGroup:
    """The links of one vehicle that forward to each other (PX4's instances with ``-f``)."""

    def __init__(self) -> None:
        self._relays: list[Relay | None] = []
        self._heard: list[set[tuple[int, int]]] = []

    def join(self, relay: Relay) -> int:
        """A new link: its member id in the group."""
        self._relays.append(relay)
        self._heard.append(set())
        return len(self._relays) - 1

    def leave(self, member: int) -> None:
        """A link closed: nothing more is forwarded to it."""
        self._relays[member] = None
        self._heard[member] = set()

    def heard(self, member: int, system: int, component: int) -> None:
        """Link ``member`` received a frame from ``system``/``component``."""
        heard = self._heard[member]
        if (system, component) not in heard:
            heard.add((system, component))

    def has_heard(self, member: int, target: tuple[int, int]) -> bool:
        """PX4's component_was_seen: whether ``member`` heard from ``target`` (0 = any)."""
        heard = self._heard[member]
        system, component = target
        if system == 0:
            return bool(heard)
        if component == 0:
            return any(s == system for s, _ in heard)
        return target in heard

    def forward(self, origin: int, frame: bytes, target: tuple[int, int] | None = None) -> int:
        """Send ``frame`` out of every member but ``origin``; returns how many links took it.

        ``target``: only to the members that have heard from it (:meth:`has_heard`).
        """
        sent = 0
        for member, relay in enumerate(self._relays):
            if member == origin or relay is None:
                continue
            if target is not None and not self.has_heard(member, target):
                continue
            relay(frame)
            sent += 1
        return sent
