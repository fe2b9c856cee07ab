"""Terrain height and height above ground from the downward range finder, as PX4's EKF2 does.

PX4's EKF2 estimates the vertical position of the terrain below the vehicle as its own state
(``terrain_vpos``, NED down, m): a random walk whose process noise grows with EKF2_TERR_NOISE and
with the horizontal speed times EKF2_TERR_GRAD, corrected by the tilt-corrected range of the
downward distance sensor (EKF2_RNG_CTRL non-zero). Height above ground (``dist_bottom`` of
vehicle_local_position) is ``terrain_vpos - z``; ALTITUDE reports the terrain's altitude AMSL
(``altitude_terrain``) and the height above it (``bottom_clearance``).

Here one scalar Kalman filter per vehicle, vectorised over the fleet:

- predict: ``P += dt² (EKF2_TERR_NOISE² + (EKF2_TERR_GRAD · v_horizontal)²)``;
- measure: ``terrain = z + (R r_pos)_z + range · R[2, 2]`` (the range along the body z axis turned
  to the vertical; r_pos = EKF2_RNG_POS_*), only for a valid reading (in range, with an echo) at a
  tilt below 45 deg (PX4's range_cos_max_tilt), noise ``EKF2_RNG_NOISE² + (EKF2_RNG_SFE · range)²``
  plus the height variance, innovation gate EKF2_RNG_GATE standard deviations;
- the first valid reading (or one rejected by the gate for longer than :data:`RESET_AFTER_S`)
  resets the state to the measurement;
- the estimate is valid while a reading was fused within :data:`VALID_FOR_S`.

Not modelled: EKF2_RNG_DELAY (readings are fused on arrival) and range aiding of the height itself
(EKF2_RNG_CTRL 1 conditional / 2 always, EKF2_RNG_A_HMAX, EKF2_RNG_A_VMAX): the height stays
GNSS/baro-aided, the range finder feeds the terrain estimate only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from autopilot_emu.params import ParamStore, param_column

COS_MAX_TILT = 0.7071
"""Cosine of the largest tilt at which a range reading is used (PX4: range_cos_max_tilt, 45 deg)."""
VALID_FOR_S = 5.0
"""How long the terrain estimate stays valid after the last fused reading, s (ASSUMED; PX4 keeps
it valid while range data is fused recently)."""
RESET_AFTER_S = 1.0
"""Readings rejected by the gate for this long reset the terrain to the measurement, s."""


@dataclass(frozen=True)
class TerrainParams:
    """EKF2 range finder and terrain parameters of N vehicles, (N,) arrays in SI units."""

    rng_ctrl: np.ndarray
    """EKF2_RNG_CTRL: 0 disabled, 1 conditional, 2 enabled."""
    rng_noise_m: np.ndarray
    """EKF2_RNG_NOISE, m."""
    rng_sfe: np.ndarray
    """EKF2_RNG_SFE, m/m."""
    rng_gate: np.ndarray
    """EKF2_RNG_GATE, standard deviations."""
    rng_pos_frd_m: np.ndarray
    """EKF2_RNG_POS_X/Y/Z, body FRD, (N, 3), m."""
    terr_noise_m_s: np.ndarray
    """EKF2_TERR_NOISE, m/s."""
    terr_grad: np.ndarray
    """EKF2_TERR_GRAD, m/m."""

    @classmethod
    def from_params(cls, params: list[ParamStore]) -> TerrainParams:
        """Read the parameters of every vehicle."""
        return cls(
            rng_ctrl=param_column(params, "EKF2_RNG_CTRL").astype(int),
            rng_noise_m=param_column(params, "EKF2_RNG_NOISE"),
            rng_sfe=param_column(params, "EKF2_RNG_SFE"),
            rng_gate=param_column(params, "EKF2_RNG_GATE"),
            rng_pos_frd_m=np.stack(
                [param_column(params, f"EKF2_RNG_POS_{a}") for a in "XYZ"], axis=1
            ),
            terr_noise_m_s=param_column(params, "EKF2_TERR_NOISE"),
            terr_grad=param_column(params, "EKF2_TERR_GRAD"),
        )


class FleetTerrain:
    """Terrain vertical position (NED down, m) under each of N vehicles."""

    def __init__(self, n: int) -> None:
        self.terrain_d_m = np.zeros(n)
        """Terrain vertical position in the local NED frame, m (valid where ``initialised``)."""
        self.variance_m2 = np.full(n, 1e4)
        self.initialised = np.zeros(n, dtype=bool)
        self.last_fused_s = np.full(n, -np.inf)
        self.last_ok_s = np.full(n, -np.inf)
        """When a reading last passed the gate (or reset the state), s."""
        self.test_ratio = np.zeros(n)
        """Range innovation test ratio of the last reading (above 1: rejected)."""
        self._last_s = np.full(n, np.nan)

    def valid(self, now_s: float) -> np.ndarray:
        """(N,) a reading was fused within :data:`VALID_FOR_S`."""
        return self.initialised & (now_s - self.last_fused_s <= VALID_FOR_S)

    def update(
        self,
        now_s: float,
        new: np.ndarray,
        range_m: np.ndarray,
        range_valid: np.ndarray,
        position_d_m: np.ndarray,
        position_d_var_m2: np.ndarray,
        velocity_ned_m_s: np.ndarray,
        rotation_frd_to_ned: np.ndarray,
        params: TerrainParams,
    ) -> None:
        """Predict to ``now_s`` and fuse the new downward readings of the vehicles in ``new``."""
        dt = np.where(np.isnan(self._last_s), 0.0, now_s - self._last_s)
        self._last_s = np.where(new, now_s, self._last_s)
        rows = new & (params.rng_ctrl > 0)
        if not rows.any():
            return
        speed = np.hypot(velocity_ned_m_s[:, 0], velocity_ned_m_s[:, 1])
        self.variance_m2 += np.where(
            rows, dt**2 * (params.terr_noise_m_s**2 + (params.terr_grad * speed) ** 2), 0.0
        )
        cos_tilt = rotation_frd_to_ned[:, 2, 2]
        usable = rows & range_valid & (cos_tilt >= COS_MAX_TILT)
        rng = np.where(usable, range_m, 0.0)
        offset_d = np.einsum("nj,nj->n", rotation_frd_to_ned[:, 2, :], params.rng_pos_frd_m)
        measured = position_d_m + offset_d + rng * cos_tilt
        r_var = params.rng_noise_m**2 + (params.rng_sfe * rng) ** 2
        s_var = self.variance_m2 + r_var + position_d_var_m2
        innov = self.terrain_d_m - measured
        self.test_ratio = np.where(usable, innov**2 / (params.rng_gate**2 * s_var), self.test_ratio)
        reset = usable & (~self.initialised | (now_s - self.last_ok_s > RESET_AFTER_S))
        fuse = usable & ~reset & (self.test_ratio <= 1.0)
        gain = self.variance_m2 / s_var
        self.terrain_d_m = np.where(
            reset, measured, np.where(fuse, self.terrain_d_m - gain * innov, self.terrain_d_m)
        )
        self.variance_m2 = np.where(
            reset, r_var, np.where(fuse, (1.0 - gain) * self.variance_m2, self.variance_m2)
        )
        done = reset | fuse
        self.initialised |= reset
        self.last_fused_s = np.where(done, now_s, self.last_fused_s)
        self.last_ok_s = np.where(done, now_s, self.last_ok_s)
