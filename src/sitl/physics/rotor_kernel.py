"""Compiled per-step kernels of the rotor model (numba; the model is :mod:`sitl.physics.rotors`).

One call per physics step does what took a dozen small numpy calls: the features
``[w_i^2, w_i v_j, v_j |v_j|]`` times the wrench map, then the first-order motor lag.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, error_model="numpy")
def wrench_and_advance(
    speed_rad_s: np.ndarray,
    command_rad_s: np.ndarray,
    velocity_flu_m_s: np.ndarray,
    wrench_map: np.ndarray,
    alpha_up: float,
    alpha_down: float,
    wrench_out: np.ndarray,
) -> None:
    """Body wrench of the current rotor speeds into ``wrench_out``, then advance the speeds.

    Args:
        speed_rad_s: ``(N, n)`` rotor speeds, rad/s; advanced in place one step towards
            ``command_rad_s`` (``w += alpha (w_cmd - w)``, alpha_up when speeding up).
        command_rad_s: ``(N, n)`` commanded speeds, rad/s.
        velocity_flu_m_s: ``(N, 1, 3)`` airspeed of each centre of mass, body FLU, m/s.
        wrench_map: ``(4 n + 3, 6)`` wrench per feature (see ``RotorModel``).
        alpha_up: lag factor ``1 - exp(-dt / tau_up)`` when speeding up.
        alpha_down: lag factor when slowing down.
        wrench_out: ``(N, 6)`` ``[F_flu, tau_flu]``, N and N m.
    """
    n_vehicles, n_rotors = speed_rad_s.shape
    for k in range(n_vehicles):
        v0 = velocity_flu_m_s[k, 0, 0]
        v1 = velocity_flu_m_s[k, 0, 1]
        v2 = velocity_flu_m_s[k, 0, 2]
        for c in range(6):
            wrench_out[k, c] = 0.0
        for i in range(n_rotors):
            w = speed_rad_s[k, i]
            wd = n_rotors + 3 * i
            for c in range(6):
                wrench_out[k, c] += (
                    w * w * wrench_map[i, c]
                    + w * v0 * wrench_map[wd, c]
                    + w * v1 * wrench_map[wd + 1, c]
                    + w * v2 * wrench_map[wd + 2, c]
                )
        q = 4 * n_rotors
        for c in range(6):
            wrench_out[k, c] += (
                abs(v0) * v0 * wrench_map[q, c]
                + abs(v1) * v1 * wrench_map[q + 1, c]
                + abs(v2) * v2 * wrench_map[q + 2, c]
            )
        for i in range(n_rotors):
            d = command_rad_s[k, i] - speed_rad_s[k, i]
            up = d * alpha_up
            down = d * alpha_down
            # Speeding up (d > 0) takes the tau_up lag, slowing down the tau_down one: as
            # ``max(a_up d, a_down d)`` when a_up >= a_down, ``min`` otherwise.
            if alpha_up >= alpha_down:
                step = up if up > down else down
            else:
                step = up if up < down else down
            speed_rad_s[k, i] += step


@numba.njit(cache=True)
def commands_from_controls(
    controls: np.ndarray, max_speed_rad_s: np.ndarray, command_rad_s: np.ndarray
) -> None:
    """Clip motor controls to [0, 1] in place (NaN becomes 0) and scale them to rotor speeds.

    Args:
        controls: ``(N, n)`` HIL_ACTUATOR_CONTROLS values, clipped in place.
        max_speed_rad_s: ``(N, n)`` rotor speed at control 1 (the supply's limit), rad/s.
        command_rad_s: ``(N, n)`` out: commanded rotor speeds, rad/s.
    """
    n_vehicles, n_rotors = command_rad_s.shape
    for k in range(n_vehicles):
        for i in range(n_rotors):
            u = controls[k, i]
            if not u > 0.0:  # NaN, or at or below 0
                u = 0.0
            elif u > 1.0:
                u = 1.0
            controls[k, i] = u
            command_rad_s[k, i] = u * max_speed_rad_s[k, i]
