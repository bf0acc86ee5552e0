"""Synthetic torque recordings as ROS bags: JointStates with efforts, and a vendor low-level
state (a Unitree ``unitree_hg/msg/LowState``-style message, simplified to the fields sescid
reads, registered as custom types). Shared by the bag torque tests."""

from __future__ import annotations

import numpy as np
from bag_gen import Builder

#: a simplified Unitree motor state and low state (the real ones carry more fields)
MOTOR_MSG = "uint8 mode\nfloat32 q\nfloat32 dq\nfloat32 ddq\nfloat32 tau_est\n"
LOW_MSG = "uint32 tick\nMotorState[35] motor_state\nuint32 crc\n"
MOTOR_TYPE, LOW_TYPE = "unitree_hg/msg/MotorState", "unitree_hg/msg/LowState"
N_MOTORS = 35


class TorqueBuilder(Builder):
    """``bag_gen.Builder`` plus efforts and the low-state types."""

    def __init__(self, ros1: bool = False):
        from rosbags.typesys import get_types_from_msg

        super().__init__(ros1)
        types = get_types_from_msg(MOTOR_MSG, MOTOR_TYPE)
        types |= get_types_from_msg(LOW_MSG, LOW_TYPE)
        self.ts.register(types)
        self.T = self.ts.types

    def joint_state_effort(self, ns, names, pos, effort):
        return self.T["sensor_msgs/msg/JointState"](
            header=self.header(ns),
            name=list(names),
            position=np.asarray(pos, dtype=float),
            velocity=np.zeros(0),
            effort=np.asarray(effort, dtype=float),
        )

    def low_state(self, tick, q, tau):
        """A low state whose motors i carry q[i], tau[i] (float32); others 0."""
        motor = self.T[MOTOR_TYPE]
        motors = [
            motor(mode=1, q=float(q[i]), dq=0.0, ddq=0.0, tau_est=float(tau[i]))
            for i in range(N_MOTORS)
        ]
        return self.T[LOW_TYPE](tick=int(tick), motor_state=motors, crc=0)


def motor_layout(joint_names, seed=3) -> list[str | None]:
    """A motor index → joint name list: the joints in a shuffled order among unused motors."""
    rng = np.random.default_rng(seed)
    slots = rng.permutation(N_MOTORS)[: len(joint_names)]
    names: list[str | None] = [None] * N_MOTORS
    for j, s in zip(joint_names, slots, strict=True):
        names[int(s)] = j
    return names
