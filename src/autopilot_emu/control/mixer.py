"""Multirotor control allocation from PX4's CA_* parameters: torque and thrust -> motor outputs.

Like PX4's control_allocator (ActuatorEffectivenessRotors), the emulator knows each vehicle's
rotors only through parameters: CA_ROTOR_COUNT rotors, rotor i at (CA_ROTOR{i}_PX,
CA_ROTOR{i}_PY) in the body FRD frame (m), thrust along body -z, and yaw moment = KM x thrust with
CA_ROTOR{i}_KM > 0 for a counter-clockwise rotor (PX4 module.yaml of control_allocator). The
effectiveness of rotor i is then (-py, px, km, 1) on (roll, pitch, yaw, thrust), and the mixer is
its pseudo-inverse, normalised as PX4's ControlAllocationPseudoInverse normalises it (see
:func:`normalised_mix`), so that a normalised torque of the rate controller asks the motors for
what PX4 asks them for and PX4's gains transfer one to one. Motor order is PX4's output order.

Thrust fractions become motor outputs through PX4's thrust model (THR_MDL_FAC, PX4's mixer_module
FunctionMotors): relative thrust = f u² + (1 - f) u for output u. PX4's default f = 0 takes thrust
as linear in the output; the simulated motors spin at a speed ∝ output with thrust ∝ speed², so
with the default, as in PX4 SITL, the loop gain varies with throttle and the hover-thrust
estimator learns the hover *output* (about 0.48 on the SDF Typhoon), not the thrust fraction.

Vehicles may have different rotor counts: outputs are (N, MAX_ROTORS) with unused outputs 0.
The allocation runs in the inner loop (:class:`autopilot_emu.control.inner_loop.InnerLoop`,
rows of ``mixer_kernel``): roll/pitch have priority; when a thrust fraction leaves 0..1 the
collective thrust is shifted to keep them, and yaw is scaled into what is left.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from autopilot_emu.params import ParamStore

MAX_ROTORS = 8
"""Rotors PX4's multicopter allocation supports (CA_ROTOR0..7)."""
PX4_ROTOR_CT = 6.5
"""PX4's default CA_ROTOR{i}_CT, thrust coefficient of the effectiveness matrix (control_allocator
module.yaml); the emulator takes it equal for every rotor."""

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


def normalised_mix(geometry: RotorGeometry) -> np.ndarray:
    """(M, 4) allocation of one vehicle: (roll, pitch, yaw, thrust) -> rotor thrust fractions.

    The pseudo-inverse of the effectiveness (-py, px, km, 1) per rotor, normalised as PX4's
    ControlAllocationPseudoInverse (updateControlAllocationMatrixScale) normalises it: roll and
    pitch share one scale, the larger of sqrt(|column|² / (k / 2)) over the two columns, k being
    the rotors with a non-zero entry (so a Quad X asks each motor for ±0.71 per unit roll torque
    and a Hexa X for ±0.58 / ±0.29 / ±0.58); yaw is divided by its column's largest entry;
    thrust by the mean thrust entry (each rotor 1 for a flat multirotor). Entries below 1e-3
    are set to 0, as PX4 does. The effectiveness carries PX4's thrust coefficient CA_ROTOR{i}_CT
    (default 6.5): it cancels out of the normalised matrix but sets which raw entries count as
    non-zero (above 1e-3), as in PX4.
    """
    m = len(geometry.moment_ratio_m)
    p = geometry.position_m
    eff = PX4_ROTOR_CT * np.stack((-p[:, 1], p[:, 0], geometry.moment_ratio_m, np.ones(m)))
    mix = np.linalg.pinv(eff)
    scales = []
    for axis in (0, 1):
        column = mix[:, axis]
        k = int(np.count_nonzero(np.abs(column) > 1e-3))
        scales.append(math.sqrt(float(column @ column) / (k / 2.0)) if k else 1.0)
    rp_scale = max(scales)
    yaw_scale = float(mix[:, 2].max())
    thrust_entries = np.abs(mix[:, 3])
    used = thrust_entries > np.finfo(np.float32).eps
    thrust_scale = float(thrust_entries[used].mean()) if used.any() else 1.0
    if rp_scale > np.finfo(np.float32).eps:
        mix[:, :2] /= rp_scale
    if yaw_scale > np.finfo(np.float32).eps:
        mix[:, 2] /= yaw_scale
    if thrust_scale > np.finfo(np.float32).eps:
        mix[:, 3] /= thrust_scale
    mix[np.abs(mix) < 1e-3] = 0.0
    return mix


@dataclass
class Mixer:
    """Pseudo-inverse allocation matrices of N vehicles, built from their rotor geometries."""

    geometries: list[RotorGeometry] = field(
        default_factory=lambda: [RotorGeometry.from_rows(TYPHOON_H480_ROTORS)]
    )
    idle_output: float = 0.15
    """Output of a spinning motor when armed with no thrust demand (PWM_MIN-like)."""
    thrust_model_factor: np.ndarray | None = None
    """(N,) THR_MDL_FAC of each vehicle, 0..1 (None: PX4's default 0, thrust linear in output)."""
    matrix: np.ndarray = field(init=False)
    """(N, MAX_ROTORS, 3) torque -> thrust-fraction columns, normalised as PX4 does."""
    thrust_column: np.ndarray = field(init=False)
    """(N, MAX_ROTORS) collective thrust -> thrust fractions, mean 1 over the used rotors."""
    used: np.ndarray = field(init=False)
    """(N, MAX_ROTORS) outputs that drive a rotor."""
    rotor_counts: np.ndarray = field(init=False)
    """(N,) rotors of each vehicle."""

    def __post_init__(self) -> None:
        n = len(self.geometries)
        factor = np.zeros(n) if self.thrust_model_factor is None else self.thrust_model_factor
        factor = np.asarray(factor, dtype=float).reshape(-1)
        if factor.shape != (n,) or not np.all((factor >= 0.0) & (factor <= 1.0)):
            raise ValueError(f"thrust_model_factor must be {n} values in 0..1, got {factor}")
        self.thrust_model_factor = factor
        self.matrix = np.zeros((n, MAX_ROTORS, 3))
        self.thrust_column = np.zeros((n, MAX_ROTORS))
        self.used = np.zeros((n, MAX_ROTORS), dtype=bool)
        for i, g in enumerate(self.geometries):
            m = len(g.moment_ratio_m)
            if m == 0:
                continue
            mix = normalised_mix(g)
            self.matrix[i, :m] = mix[:, :3]
            self.thrust_column[i, :m] = mix[:, 3]
            self.used[i, :m] = True
        self.rotor_counts = self.used.sum(axis=1)

    @classmethod
    def from_params(cls, params: list[ParamStore], idle_output: float = 0.15) -> Mixer:
        """From each vehicle's CA_ROTOR* parameters and THR_MDL_FAC."""
        factor = np.array([float(p.get("THR_MDL_FAC")) for p in params])
        return cls([RotorGeometry.from_params(p) for p in params], idle_output, factor)

    def same_rotors(self, geometries: list[RotorGeometry]) -> bool:
        """True when ``geometries`` are the rotor layouts this allocation was built from."""
        return all(
            g.moment_ratio_m.tolist() == o.moment_ratio_m.tolist()
            and g.position_m.tolist() == o.position_m.tolist()
            for g, o in zip(geometries, self.geometries, strict=True)
        )
