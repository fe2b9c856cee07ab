"""The PyBullet scene: one DIRECT client, a ground plane and one rigid body per vehicle.

Only the calls PyBullet has no batched form of are made per vehicle (read pose and velocity, apply
force and torque); everything else works on ``(N, ...)`` arrays. Forces and torques are applied in
the WORLD frame (PyBullet's LINK_FRAME torque on a base is unreliable).
"""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from sitl.physics.bullet_import import pybullet as p
from sitl.physics.earth import GRAVITY_M_S2
from sitl.physics.state_kernel import complete_state, wrench_to_world

_STATE_WIDTH = 22  # position 3, quaternion 4, velocity 3, angular velocity 3, rotation matrix 9


GROUND_TILE_M = 20.0
"""Side of the square of ground one repetition of the ground texture covers, m (the cameras
draw the ground, ``sitl.sensors.camera_ground``; PyBullet holds only its collision plane)."""


def _hidden_ground_visual(cid: int) -> int:
    """A visual shape for the ground that no camera ever draws: one tiny triangle far below.

    The cameras draw the ground themselves (``sitl.sensors.camera_ground``: analytically, per
    pixel ray, much cheaper than TinyRenderer's rasteriser). Without any visual shape PyBullet's
    renderer would draw the collision plane instead; this triangle, 10 km under the ground and
    a micrometre wide, covers no pixel of any view.
    """
    z = -1.0e4
    return p.createVisualShape(
        p.GEOM_MESH,
        vertices=[[0.0, 0.0, z], [1.0e-6, 0.0, z], [0.0, 1.0e-6, z]],
        indices=[0, 1, 2],
        physicsClientId=cid,
    )


class BulletScene:
    """PyBullet world (ENU, z up, ground plane at z = 0) holding one rigid body per vehicle."""

    def __init__(
        self,
        urdf_paths: Sequence[Path],
        spawn_positions_enu_m: np.ndarray,
        spawn_quaternion_xyzw: tuple[float, float, float, float],
        dt_s: float,
        ground_friction: float = 1.0,
    ) -> None:
        self._cid = p.connect(p.DIRECT)
        if self._cid < 0:
            raise RuntimeError("could not start a PyBullet DIRECT client")
        cid = self._cid
        p.resetSimulation(physicsClientId=cid)
        p.setGravity(0.0, 0.0, -GRAVITY_M_S2, physicsClientId=cid)
        p.setPhysicsEngineParameter(
            fixedTimeStep=dt_s,
            numSubSteps=0,
            # Contacts are only skids resting on flat ground; 10 solver iterations hold them as
            # still as the default 50 and halve the cost of a step with N vehicles on the ground.
            numSolverIterations=10,
            deterministicOverlappingPairs=1,
            physicsClientId=cid,
        )
        plane = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid)
        self.ground_id = p.createMultiBody(
            0.0, plane, _hidden_ground_visual(cid), physicsClientId=cid
        )
        # Zero collision margin: shapes are exactly as the URDF says, so a vehicle spawned at its
        # resting height does not pop up by PyBullet's default 1 mm margin.
        p.changeDynamics(
            self.ground_id,
            -1,
            lateralFriction=ground_friction,
            restitution=0.0,
            collisionMargin=0.0,
            physicsClientId=cid,
        )

        positions = np.asarray(spawn_positions_enu_m, dtype=float)
        if len(urdf_paths) != len(positions):
            self.close()
            raise ValueError(f"{len(urdf_paths)} URDF paths for {len(positions)} spawn positions")
        self.body_ids: list[int] = []
        for urdf_path, position in zip(urdf_paths, positions, strict=True):
            try:
                body = p.loadURDF(
                    str(urdf_path),
                    basePosition=position.tolist(),
                    baseOrientation=list(spawn_quaternion_xyzw),
                    flags=p.URDF_USE_INERTIA_FROM_FILE,
                    physicsClientId=cid,
                )
            except p.error as exc:
                self.close()
                raise ValueError(f"{urdf_path}: PyBullet could not load it ({exc})") from exc
            p.changeDynamics(
                body,
                -1,
                linearDamping=0.0,
                angularDamping=0.0,
                lateralFriction=ground_friction,
                restitution=0.0,
                collisionMargin=0.0,
                activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING,
                physicsClientId=cid,
            )
            self.body_ids.append(body)

        n = len(self.body_ids)
        self._state = np.zeros((n, _STATE_WIDTH))
        s = self._state
        self.position_enu_m = s[:, 0:3]
        """Centre-of-mass positions, ENU, m, (N, 3) view (valid after ``read_state``)."""
        self.quaternion_xyzw = s[:, 3:7]
        """Attitudes FLU->ENU, (x, y, z, w), (N, 4) view."""
        self.velocity_enu_m_s = s[:, 7:10]
        """Centre-of-mass velocities, ENU, m/s, (N, 3) view."""
        self.angular_velocity_enu_rad_s = s[:, 10:13]
        """Angular velocities in world ENU axes, rad/s, (N, 3) view."""
        self.rotation = s[:, 13:22].reshape(n, 3, 3)
        """Rotation matrices FLU->ENU (``v_enu = R @ v_flu``), (N, 3, 3) view."""
        assert np.shares_memory(self.rotation, s), "rotation must be a view of the state"
        self.velocity_flu_m_s = np.zeros((n, 1, 3))
        """Centre-of-mass velocities in body FLU axes, m/s, (N, 1, 3) (valid after read_state)."""
        self._wrench_world = np.zeros((n, 2, 3))
        self._read = np.zeros(13 * n)
        """What PyBullet returned, 13 values per body (the kernel spreads them into the state)."""
        self.read_state()

    @property
    def client_id(self) -> int:
        """PyBullet physics client id."""
        return self._cid

    def read_state(self) -> None:
        """Copy every body's pose and velocity from PyBullet into the state arrays."""
        cid = self._cid
        get_pose = p.getBasePositionAndOrientation
        get_vel = p.getBaseVelocity
        values: list[float] = []
        extend = values.extend
        for body in self.body_ids:
            pos, orn = get_pose(body, cid)
            lin, ang = get_vel(body, cid)
            extend(pos)
            extend(orn)
            extend(lin)
            extend(ang)
        self._read[:] = values
        complete_state(self._read, self._state, self.velocity_flu_m_s)

    def apply_body_wrench_and_step(self, wrench_flu: np.ndarray) -> None:
        """Apply [F_flu, tau_flu] ``(N, 6)`` at each centre of mass, step once, read the state."""
        wrench_to_world(wrench_flu, self._state, self._wrench_world)
        cid = self._cid
        world = p.WORLD_FRAME
        apply_force = p.applyExternalForce
        apply_torque = p.applyExternalTorque
        for body, (force, torque), pos in zip(
            self.body_ids, self._wrench_world.tolist(), self.position_enu_m.tolist(), strict=True
        ):
            apply_force(body, -1, force, pos, world, cid)
            apply_torque(body, -1, torque, world, cid)
        p.stepSimulation(cid)
        self.read_state()

    def close(self) -> None:
        """Disconnect the PyBullet client (idempotent)."""
        if self._cid >= 0:
            with contextlib.suppress(p.error):
                p.disconnect(physicsClientId=self._cid)
            self._cid = -1
