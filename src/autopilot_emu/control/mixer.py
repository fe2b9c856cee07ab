"""Hexa-X control allocation: normalised torque and thrust -> six motor outputs (0..1).

Geometry is PX4's Hexa X (airframe typhoon_h480, SYS_AUTOSTART 6011): motor i at (x, y) in the
body FRD frame with spin direction CW/CCW; motor order is PX4's output order. The emulator does
not know the simulator's constants: like PX4 it only knows rotor positions and directions, and
assumes thrust ∝ output² (THR_MDL_FAC = 1, since rotor speed ∝ output and thrust ∝ speed²).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# (x_m, y_m, direction) per output; direction +1 = CCW (seen from above), -1 = CW.
HEXA_X_ROTORS: tuple[tuple[float, float, int], ...] = (
    (-0.00187896, 0.242705, -1),  # motor 1: right, CW
    (-0.00187896, -0.242705, 1),  # motor 2: left, CCW
    (0.211396, -0.119762, -1),  # motor 3: front left, CW
    (-0.209396, 0.122762, 1),  # motor 4: rear right, CCW
    (0.211396, 0.119762, 1),  # motor 5: front right, CCW
    (-0.209396, -0.122762, -1),  # motor 6: rear left, CW
)
YAW_MOMENT_RATIO = 0.06
"""Rotor yaw moment per unit thrust, m (PX4 Gazebo model momentConstant)."""


@dataclass
class Mixer:
    """Pseudo-inverse allocation with roll/pitch priority over yaw and thrust."""

    rotors: tuple[tuple[float, float, int], ...] = HEXA_X_ROTORS
    idle_output: float = 0.15
    """Output of a spinning motor when armed with no thrust demand (PWM_MIN-like)."""
    matrix: np.ndarray = field(init=False)
    """(6, 3) torque -> thrust-fraction columns, each scaled to a peak of 1."""
    thrust_column: np.ndarray = field(init=False)
    """(6,) collective thrust -> thrust fractions, mean 1 (uneven when the CoM is off-centre)."""

    def __post_init__(self) -> None:
        r = np.asarray(self.rotors, dtype=float)
        eff = np.stack((-r[:, 1], r[:, 0], r[:, 2] * YAW_MOMENT_RATIO, np.ones(len(r))))
        mix = np.linalg.pinv(eff)
        self.matrix = mix[:, :3] / np.abs(mix[:, :3]).max(axis=0)
        self.thrust_column = mix[:, 3] / mix[:, 3].mean()

    def mix(self, torque: np.ndarray, thrust: np.ndarray) -> np.ndarray:
        """Motor outputs (N, 6) for torque (N, 3) in -1..1 and collective thrust (N,) in 0..1."""
        thr = thrust[:, None] * self.thrust_column
        fractions = thr + torque @ self.matrix.T
        if fractions.max() > 1.0 or fractions.min() < 0.0:
            fractions = self._desaturate(thr, torque[:, :2] @ self.matrix[:, :2].T,
                                         torque[:, 2:3] * self.matrix[:, 2])  # fmt: skip
        return np.maximum(np.sqrt(fractions), self.idle_output)

    @staticmethod
    def _desaturate(thr: np.ndarray, t_rp: np.ndarray, t_y: np.ndarray) -> np.ndarray:
        """Keep roll/pitch by shifting collective thrust, then scale yaw into what is left."""
        hi = (thr + t_rp).max(axis=1, keepdims=True)
        lo = (thr + t_rp).min(axis=1, keepdims=True)
        thr = thr - np.maximum(hi - 1.0, 0.0) + np.maximum(-lo, 0.0)
        base = thr + t_rp
        room_up = np.where(t_y > 0, (1.0 - base) / np.maximum(t_y, 1e-9), np.inf)
        room_dn = np.where(t_y < 0, base / np.maximum(-t_y, 1e-9), np.inf)
        k = np.clip(np.minimum(room_up, room_dn).min(axis=1, keepdims=True), 0.0, 1.0)
        return np.clip(base + k * t_y, 0.0, 1.0)
