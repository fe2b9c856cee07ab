"""Ground truth of the fleet at one instant: what the physics knows, without sensor errors."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from sitl import frames


@dataclass(frozen=True)
class TruthState:
    """True state of N vehicles at one simulation time (arrays are copies, safe to keep)."""

    time_s: float
    """Simulation time, s."""
    position_enu_m: np.ndarray
    """Centre-of-mass positions, world ENU, m, (N, 3)."""
    velocity_enu_m_s: np.ndarray
    """Centre-of-mass velocities, world ENU, m/s, (N, 3)."""
    quaternion_xyzw: np.ndarray
    """Attitudes, body FLU -> world ENU, (x, y, z, w), (N, 4)."""
    angular_velocity_body_frd_rad_s: np.ndarray
    """Angular velocities in body FRD axes, rad/s, (N, 3)."""
    rotor_speed_rad_s: np.ndarray
    """Rotor speeds, in actuator output order, rad/s, (N, n_rotors)."""
    electrical_power_w: np.ndarray
    """Electrical power of each vehicle (rotors at their present speeds + loads), W, (N,)."""
    battery_voltage_v: np.ndarray
    """Supply terminal voltage (at the last power update), V, (N,)."""
    battery_current_a: np.ndarray
    """Supply current (at the last power update), A, (N,)."""
    battery_soc: np.ndarray
    """State of charge of each pack, 0..1, (N,)."""
    tilt_rad: np.ndarray
    """Angle between body up and world up, rad, (N,)."""
    wind_enu_m_s: np.ndarray
    """Wind velocity at each centre of mass (steady + turbulence + gusts), ENU, m/s, (N, 3)."""
    origin: frames.GeodeticOrigin
    """Geodetic position of the world origin."""

    @cached_property
    def _geodetic(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return frames.enu_to_geodetic(self.position_enu_m, self.origin)

    @property
    def lat_deg(self) -> np.ndarray:
        """Latitudes, degrees, (N,)."""
        return self._geodetic[0]

    @property
    def lon_deg(self) -> np.ndarray:
        """Longitudes, degrees, (N,)."""
        return self._geodetic[1]

    @property
    def alt_amsl_m(self) -> np.ndarray:
        """Altitudes above mean sea level, m, (N,)."""
        return self._geodetic[2]

    @property
    def position_ned_m(self) -> np.ndarray:
        """Centre-of-mass positions, world NED about the origin, m, (N, 3)."""
        return frames.enu_to_ned(self.position_enu_m)

    @property
    def velocity_ned_m_s(self) -> np.ndarray:
        """Centre-of-mass velocities, NED, m/s, (N, 3)."""
        return frames.enu_to_ned(self.velocity_enu_m_s)

    @property
    def quaternion_ned_frd_wxyz(self) -> np.ndarray:
        """Attitudes, body FRD -> world NED, (w, x, y, z) as PX4, (N, 4)."""
        return frames.quat_enu_flu_to_ned_frd(self.quaternion_xyzw)

    @property
    def euler_ned_frd_rad(self) -> np.ndarray:
        """PX4 Euler angles (roll, pitch, yaw; yaw 0 = north), rad, (N, 3)."""
        return frames.euler_from_quat_ned_frd(self.quaternion_ned_frd_wxyz)
