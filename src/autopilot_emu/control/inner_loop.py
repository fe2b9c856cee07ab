"""The per-IMU-sample control loop of the fleet: gyro filters, attitude P, rate PID, mixer.

As PX4's vehicle_angular_velocity (IMU_GYRO_CUTOFF and IMU_DGYRO_CUTOFF low-passes,
``gyro_filter_kernel``), mc_att_control (quaternion P law, ``attitude_kernel``), mc_rate_control
(PID whose D term acts on the filtered angular acceleration, ``rate_kernel``) and
control_allocator with the motors' thrust model (``mixer_kernel``, the allocation of
:class:`~autopilot_emu.control.mixer.Mixer`), fused into one compiled call,
``inner_loop_kernel``, behind one entry point, :meth:`InnerLoop.step`. Offboard body-rate
setpoints replace the attitude loop's per axis; inactive vehicles idle, disarmed ones output 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from autopilot_emu.control.gyro_filter import pass_through, rate_filter_coefficients
from autopilot_emu.control.inner_loop_kernel import inner_loop_kernel
from autopilot_emu.control.mixer import MAX_ROTORS, Mixer, RotorGeometry
from autopilot_emu.params import ParamStore, param_column

RATE_INTEGRATOR_LIMIT = 0.3
"""Bound of each body-rate integrator, normalised torque."""


@dataclass(frozen=True)
class InnerLoopGains:
    """MC_* gains of every vehicle ((N, 3) over roll, pitch, yaw) and its gyro filters.

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
    filters: np.ndarray | None = None
    """(2, N, 5) low-pass coefficients (b0, b1, b2, a1, a2) of the angular velocity
    (IMU_GYRO_CUTOFF) and of the angular acceleration (IMU_DGYRO_CUTOFF); None: unfiltered."""
    packed: np.ndarray = field(init=False)
    """(5, N, 3) the gains above stacked in that order, for ``inner_loop_kernel``."""

    def __post_init__(self) -> None:
        # Kernel arguments cost per array: stack what only changes with the parameters.
        packed = np.stack(
            (self.attitude_p, self.rate_max_rad_s, self.rate_p, self.rate_i, self.rate_d)
        )
        object.__setattr__(self, "packed", packed)
        if self.filters is None:
            object.__setattr__(self, "filters", pass_through(len(self.attitude_p)))

    @classmethod
    def from_params(cls, params: list[ParamStore], sample_rate_hz: float) -> InnerLoopGains:
        """Read the parameters of every vehicle; the filters are built for ``sample_rate_hz``.

        MC_*RATE_K scales the P, I and D gains of its axis, as in PX4's mc_rate_control.
        """

        def rpy(fmt: str) -> np.ndarray:
            axes = ("ROLL", "PITCH", "YAW")
            return np.stack([param_column(params, fmt.format(a)) for a in axes], axis=1)

        k = rpy("MC_{}RATE_K")
        return cls(
            attitude_p=rpy("MC_{}_P"),
            rate_max_rad_s=np.radians(rpy("MC_{}RATE_MAX")),
            rate_p=k * rpy("MC_{}RATE_P"),
            rate_i=k * rpy("MC_{}RATE_I"),
            rate_d=k * rpy("MC_{}RATE_D"),
            filters=rate_filter_coefficients(
                param_column(params, "IMU_GYRO_CUTOFF"),
                param_column(params, "IMU_DGYRO_CUTOFF"),
                sample_rate_hz,
            ),
        )


@dataclass
class InnerLoopState:
    """What the inner loop keeps between samples and writes, (N, ...) arrays."""

    rate_integral: np.ndarray
    """(N, 3) body-rate integrators, normalised torque (±``RATE_INTEGRATOR_LIMIT``)."""
    filter_state: np.ndarray
    """(N, 3, 5) per axis: the velocity filter's two delays, the acceleration filter's two, and
    the previous filtered rate (rad/s) the acceleration is differentiated from."""
    filter_primed: np.ndarray
    """(N,) the filters have seen a finite sample (the first one settles them)."""
    rates_filtered_rad_s: np.ndarray
    """(N, 3) body rates after IMU_GYRO_CUTOFF, what the P and I terms act on, rad/s."""
    angular_accel_rad_s2: np.ndarray
    """(N, 3) angular acceleration after IMU_DGYRO_CUTOFF, what the D term acts on, rad/s²."""
    rate_sp_rad_s: np.ndarray
    """(N, 3) body-rate setpoints of the last sample, rad/s."""
    outputs: np.ndarray
    """(N, MAX_ROTORS) motor outputs 0..1 in PX4's output order; unused outputs 0."""

    @classmethod
    def zeros(cls, n: int) -> InnerLoopState:
        """State of n vehicles at rest."""
        return cls(
            rate_integral=np.zeros((n, 3)),
            filter_state=np.zeros((n, 3, 5)),
            filter_primed=np.zeros(n, dtype=bool),
            rates_filtered_rad_s=np.zeros((n, 3)),
            angular_accel_rad_s2=np.zeros((n, 3)),
            rate_sp_rad_s=np.zeros((n, 3)),
            outputs=np.zeros((n, MAX_ROTORS)),
        )


class InnerLoop:
    """Attitude, rate control and allocation of N vehicles, one compiled call per IMU sample."""

    def __init__(self, gains: InnerLoopGains, mixer: Mixer, sample_rate_hz: float = 250.0) -> None:
        self.gains = gains
        self.mixer = mixer
        self.sample_rate_hz = sample_rate_hz
        """Rate the filters are designed for (the IMU rate), Hz."""
        self.state = InnerLoopState.zeros(len(mixer.geometries))

    @classmethod
    def from_params(cls, params: list[ParamStore], sample_rate_hz: float = 250.0) -> InnerLoop:
        """The loop of every vehicle, its gains, filters and mixer from its parameters."""
        return cls(
            InnerLoopGains.from_params(params, sample_rate_hz),
            Mixer.from_params(params),
            sample_rate_hz,
        )

    def set_params(self, params: list[ParamStore]) -> None:
        """New parameters: new gains and filters; a new mixer where rotors or THR_MDL_FAC changed.

        The filters' state carries on, as PX4's does when only a cutoff changes.
        """
        self.gains = InnerLoopGains.from_params(params, self.sample_rate_hz)
        geometries = [RotorGeometry.from_params(p) for p in params]
        factor = np.array([float(p.get("THR_MDL_FAC")) for p in params])
        same_factor = np.array_equal(factor, self.mixer.thrust_model_factor)
        if not (self.mixer.same_rotors(geometries) and same_factor):
            self.mixer = Mixer(geometries, self.mixer.idle_output, factor)

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
            q, rates_rad_s, q_sp, thrust, self.gains.packed, self.gains.filters, overridden,
            rate_target_rad_s, dt_s, active, armed, RATE_INTEGRATOR_LIMIT, s.rate_integral,
            s.filter_state, s.filter_primed, m.matrix, m.thrust_column, m.used, m.idle_output,
            m.thrust_model_factor, s.rates_filtered_rad_s, s.angular_accel_rad_s2,
            s.rate_sp_rad_s, s.outputs,
        )  # fmt: skip
