"""Multirotor control allocation from PX4's CA_* parameters: torque and thrust -> motor outputs.

Like PX4's control_allocator (ActuatorEffectivenessRotors), the emulator knows each vehicle's
rotors only through parameters: CA_ROTOR_COUNT rotors, rotor i at (CA_ROTOR{i}_PX,
CA_ROTOR{i}_PY) in the body FRD frame (m), thrust along body -z, and yaw moment = KM x thrust with
CA_ROTOR{i}_KM > 0 for a counter-clockwise rotor (PX4 module.yaml of control_allocator). The
effectiveness of rotor i is then (-py, px, km, 1) on (roll, pitch, yaw, thrust), and the mixer is
its pseudo-inverse. Motor order is PX4's output order. Thrust is taken ∝ output² (rotor speed ∝
output, thrust ∝ speed², i.e. THR_MDL_FAC = 1).

Vehicles may have different rotor counts: outputs are (N, MAX_ROTORS) with unused outputs 0.
The allocation runs in the inner loop (:class:`autopilot_emu.control.inner_loop.InnerLoop`,
rows of ``mixer_kernel``): roll/pitch have priority; when a thrust fraction leaves 0..1 the
collective thrust is shifted to keep them, and yaw is scaled into what is left.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from autopilot_emu.params import ParamStore

MAX_ROTORS = 8
"""Rotors PX4's multicopter allocation supports (CA_ROTOR0..7)."""

# Typhoon H480 (PX4 airframe 6011_gazebo-classic_typhoon_h480, Hexa X): (x_m, y_m, KM) per
# output; rotor positions from the typhoon_h480 SDF, KM = ±momentConstant 0.06 (+ = CCW).
TYPHOON_H480_ROTORS: tuple[tuple[float, float, float], ...] = (
    (-0.00187896, 0.242705, -0.06),  # motor 1: right, CW
    (-0.00187896, -0.242705, 0.06),  # motor 2: left, CCW
    (0.211396, -0.119762, -0.06),  # motor 3: front left, CW
    (-0.209396, 0.122762, 0.06),  # motor 4: rear right, CCW
    (0.211396, 0.119762, 0.06),  # motor 5: front right, CCW
    (-0.209396, -0.122762, -0.06),  # motor 6: rear left, CW
)


@dataclass(frozen=True)
class RotorGeometry:
    """Rotor layout of one vehicle, as PX4's CA_ROTOR* parameters give it."""

    position_m: np.ndarray
    """(M, 2) rotor x, y in the body FRD frame, m."""
    moment_ratio_m: np.ndarray
    """(M,) yaw moment per unit thrust (CA_ROTOR{i}_KM), m; positive for a CCW rotor."""

    def __post_init__(self) -> None:
        m = len(self.moment_ratio_m)
        if m > MAX_ROTORS or self.position_m.shape != (m, 2):
            raise ValueError(f"need 0..{MAX_ROTORS} rotors with (x, y) each, got {m}")

    @classmethod
    def from_rows(cls, rows: tuple[tuple[float, float, float], ...]) -> RotorGeometry:
        """From (x_m, y_m, km) rows."""
        r = np.asarray(rows, dtype=float).reshape(-1, 3)
        return cls(r[:, :2].copy(), r[:, 2].copy())

    @classmethod
    def from_params(cls, params: ParamStore) -> RotorGeometry:
        """From CA_ROTOR_COUNT and CA_ROTOR{i}_PX / _PY / _KM."""
        count = int(params.get("CA_ROTOR_COUNT"))
        rows = tuple(
            tuple(float(params.get(f"CA_ROTOR{i}_{k}")) for k in ("PX", "PY", "KM"))
            for i in range(count)
        )
        return cls.from_rows(rows)  # type: ignore[arg-type]


@dataclass
class Mixer:
    """Pseudo-inverse allocation matrices of N vehicles, built from their rotor geometries."""

    geometries: list[RotorGeometry] = field(
        default_factory=lambda: [RotorGeometry.from_rows(TYPHOON_H480_ROTORS)]
    )
    idle_output: float = 0.15
    """Output of a spinning motor when armed with no thrust demand (PWM_MIN-like)."""
    matrix: np.ndarray = field(init=False)
    """(N, MAX_ROTORS, 3) torque -> thrust-fraction columns, each scaled to a peak of 1."""
    thrust_column: np.ndarray = field(init=False)
    """(N, MAX_ROTORS) collective thrust -> thrust fractions, mean 1 over the used rotors."""
    used: np.ndarray = field(init=False)
    """(N, MAX_ROTORS) outputs that drive a rotor."""
    rotor_counts: np.ndarray = field(init=False)
    """(N,) rotors of each vehicle."""

    def __post_init__(self) -> None:
        n = len(self.geometries)
        self.matrix = np.zeros((n, MAX_ROTORS, 3))
        self.thrust_column = np.zeros((n, MAX_ROTORS))
        self.used = np.zeros((n, MAX_ROTORS), dtype=bool)
        for i, g in enumerate(self.geometries):
            m = len(g.moment_ratio_m)
            if m == 0:
                continue
            eff = np.stack((-g.position_m[:, 1], g.position_m[:, 0], g.moment_ratio_m, np.ones(m)))
            mix = np.linalg.pinv(eff)
            peak = np.maximum(np.abs(mix[:, :3]).max(axis=0), 1e-12)
            self.matrix[i, :m] = mix[:, :3] / peak
            self.thrust_column[i, :m] = mix[:, 3] / mix[:, 3].mean()
            self.used[i, :m] = True
        self.rotor_counts = self.used.sum(axis=1)

    @classmethod
    def from_params(cls, params: list[ParamStore], idle_output: float = 0.15) -> Mixer:
        """From each vehicle's CA_ROTOR* parameters."""
        return cls([RotorGeometry.from_params(p) for p in params], idle_output)

    def same_rotors(self, geometries: list[RotorGeometry]) -> bool:
        """True when ``geometries`` are the rotor layouts this allocation was built from."""
        return all(
            g.moment_ratio_m.tolist() == o.moment_ratio_m.tolist()
            and g.position_m.tolist() == o.position_m.tolist()
            for g, o in zip(geometries, self.geometries, strict=True)
        )
