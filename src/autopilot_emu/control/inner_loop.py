"""The per-IMU-sample control loop of the fleet: attitude P -> body-rate PID -> mixer.

As PX4's mc_att_control (quaternion P law, ``attitude_kernel``), mc_rate_control (PID with the
derivative on the measurement, ``rate_kernel``) and control_allocator (``mixer_kernel``, the
allocation of :class:`~autopilot_emu.control.mixer.Mixer`), fused into one compiled call,
``inner_loop_kernel``, behind one entry point, :meth:`InnerLoop.step`. Offboard body-rate
setpoints replace the attitude loop's per axis; inactive vehicles idle, disarmed ones output 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from autopilot_emu.control.inner_loop_kernel import inner_loop_kernel
from autopilot_emu.control.mixer import MAX_ROTORS, Mixer, RotorGeometry
from autopilot_emu.params import ParamStore, param_column

RATE_INTEGRATOR_LIMIT = 0.3
"""Bound of each body-rate integrator, normalised torque."""


@dataclass(frozen=True)
class InnerLoopGains:
    """MC_* attitude and rate gains of every vehicle, (N, 3) arrays over roll, pitch, yaw.

    Frozen: a parameter change builds new gains (:meth:`from_params`).
    """

    attitude_p: np.ndarray
    """MC_ROLL_P, MC_PITCH_P, MC_YAW_P: body rate per attitude error, 1/s."""
    rate_max_rad_s: np.ndarray
    """MC_ROLLRATE_MAX, MC_PITCHRATE_MAX, MC_YAWRATE_MAX, rad/s."""
    rate_p: np.ndarray
    """MC_*RATE_P: normalised torque per rad/s of rate error."""
    rate_i: np.ndarray
    """MC_*RATE_I: normalised torque per rad of integrated rate error."""
    rate_d: np.ndarray
    """MC_*RATE_D: normalised torque per rad/s² of rate change."""
    packed: np.ndarray = field(init=False)
    """(5, N, 3) the gains above stacked in that order, for ``inner_loop_kernel``."""

    def __post_init__(self) -> None:
        # Kernel arguments cost per array: stack what only changes with the parameters.
        packed = np.stack(
            (self.attitude_p, self.rate_max_rad_s, self.rate_p, self.rate_i, self.rate_d)
        )
        object.__setattr__(self, "packed", packed)

    @classmethod
    def from_params(cls, params: list[ParamStore]) -> InnerLoopGains:
        """Read the parameters of every vehicle."""

        def rpy(fmt: str) -> np.ndarray:
            axes = ("ROLL", "PITCH", "YAW")
            return np.stack([param_column(params, fmt.format(a)) for a in axes], axis=1)

        return cls(
            attitude_p=rpy("MC_{}_P"),
            rate_max_rad_s=np.radians(rpy("MC_{}RATE_MAX")),
            rate_p=rpy("MC_{}RATE_P"),
            rate_i=rpy("MC_{}RATE_I"),
            rate_d=rpy("MC_{}RATE_D"),
        )


@dataclass
class InnerLoopState:
    """What the inner loop keeps between samples and writes, (N, ...) arrays."""

    rate_integral: np.ndarray
    """(N, 3) body-rate integrators, normalised torque (±``RATE_INTEGRATOR_LIMIT``)."""
    prev_rates_rad_s: np.ndarray
    """(N, 3) body rates of the previous sample (derivative on measurement), rad/s."""
    rate_sp_rad_s: np.ndarray
    """(N, 3) body-rate setpoints of the last sample, rad/s."""
    outputs: np.ndarray
    """(N, MAX_ROTORS) motor outputs 0..1 in PX4's output order; unused outputs 0."""

    @classmethod
    def zeros(cls, n: int) -> InnerLoopState:
        """State of n vehicles at rest."""
        return cls(np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, MAX_ROTORS)))


class InnerLoop:
    """Attitude, rate control and allocation of N vehicles, one compiled call per IMU sample."""

    def __init__(self, gains: InnerLoopGains, mixer: Mixer) -> None:
        self.gains = gains
        self.mixer = mixer
        self.state = InnerLoopState.zeros(len(mixer.geometries))

    @classmethod
    def from_params(cls, params: list[ParamStore]) -> InnerLoop:
        """The loop of every vehicle, its gains and mixer from its parameters."""
        return cls(InnerLoopGains.from_params(params), Mixer.from_params(params))

    def set_params(self, params: list[ParamStore]) -> None:
        """New parameters: new gains; a new mixer only where the rotor layout changed."""
        self.gains = InnerLoopGains.from_params(params)
        geometries = [RotorGeometry.from_params(p) for p in params]
        if not self.mixer.same_rotors(geometries):
            self.mixer = Mixer(geometries, self.mixer.idle_output)

    def step(
        self,
        *,
        q: np.ndarray,
        rates_rad_s: np.ndarray,
        q_sp: np.ndarray,
        thrust: np.ndarray,
        overridden: np.ndarray,
        rate_target_rad_s: np.ndarray,
        dt_s: float,
        active: np.ndarray,
        armed: np.ndarray,
    ) -> None:
        """One control tick of every vehicle: writes ``state`` (rate setpoints, outputs).

        Estimated attitude ``q`` and setpoint ``q_sp`` (N, 4) wxyz, body rates (N, 3) rad/s,
        collective thrust (N,) 0..1. Where ``overridden``, the finite entries of
        ``rate_target_rad_s`` (offboard body rates) replace the attitude loop's. The integrator
        runs only for ``active`` vehicles; inactive ones idle, disarmed ones output 0.
        """
        s, m = self.state, self.mixer
        inner_loop_kernel(
            q, rates_rad_s, q_sp, thrust, self.gains.packed, overridden, rate_target_rad_s, dt_s,
            active, armed, RATE_INTEGRATOR_LIMIT, s.rate_integral, s.prev_rates_rad_s, m.matrix,
            m.thrust_column, m.used, m.idle_output, s.rate_sp_rad_s, s.outputs,
        )  # fmt: skip
