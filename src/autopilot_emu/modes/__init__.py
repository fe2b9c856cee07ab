"""PX4 flight modes as they appear in HEARTBEAT.custom_mode and MAV_CMD_DO_SET_MODE.

Each mode's setpoint logic is a module of this package: :mod:`.takeoff`, :mod:`.land`, :mod:`.rtl`,
:mod:`.hold` (Hold and Reposition), :mod:`.mission` and :mod:`.offboard`; they read a
:class:`~.nav_types.NavInput` and write a :class:`~.nav_types.NavOutput`. Which mode runs, and
when the vehicle may switch, is the commander's (:mod:`autopilot_emu.commander`).
"""

from __future__ import annotations

from enum import IntEnum


class MainMode(IntEnum):
    """PX4 main modes (px4_custom_mode.h)."""

    MANUAL = 1
    ALTCTL = 2
    POSCTL = 3
    AUTO = 4
    ACRO = 5
    OFFBOARD = 6
    STABILIZED = 7
    RATTITUDE = 8


class AutoSubMode(IntEnum):
    """PX4 AUTO sub modes."""

    NONE = 0
    READY = 1
    TAKEOFF = 2
    LOITER = 3
    MISSION = 4
    RTL = 5
    LAND = 6
    FOLLOW_TARGET = 8
    PRECLAND = 9


class LandedState(IntEnum):
    """MAV_LANDED_STATE values reported in EXTENDED_SYS_STATE."""

    UNDEFINED = 0
    ON_GROUND = 1
    IN_AIR = 2
    TAKEOFF = 3
    LANDING = 4


def custom_mode(main: int, sub: int) -> int:
    """HEARTBEAT.custom_mode: main mode in byte 2, sub mode in byte 3."""
    return (int(main) << 16) | (int(sub) << 24)
