"""Frames and rotations (MODEL.md, "Frames and state").

The plane's normal, contact tangents and uphill direction for an incline, and
quaternion/matrix conversions.
"""

from __future__ import annotations

import math

import numpy as np


def plane_frame(incline_deg: float) -> dict[str, np.ndarray]:
    """Plane normal ``n``, contact tangents ``t``, ``o`` and uphill direction ``u``."""
    th = math.radians(incline_deg)
    s, c = math.sin(th), math.cos(th)
    return {
        "n": np.array([0.0, s, c]),
        "t": np.array([1.0, 0.0, 0.0]),
        "o": np.array([0.0, c, -s]),
        "u": np.array([0.0, -c, s]),
    }


def rot_to_quat(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (scalar first) of a rotation matrix."""
    tr = np.trace(R)
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = [0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        s = math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2]) * 2
        q = [(R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif R[1, 1] > R[2, 2]:
        s = math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2]) * 2
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s]
    else:
        s = math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1]) * 2
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s]
    qa = np.array(q)
    return qa / np.linalg.norm(qa)


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices of quaternions ``q[..., 4]`` (scalar first)."""
    w, x, y, z = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
    return np.stack(
        [
            np.stack([w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z], -1),
        ],
        -2,
    )
