"""The path Baxter's joint trajectory action server commands between waypoints:
cubic Bézier segments of an interpolating cubic B-spline, as Rethink's
`joint_trajectory_action` (baxter_interface 1.2.0, its `bezier` module) builds
them. Written from that construction, not copied.

Each joint is splined on its own, through the waypoints' positions only (the
real server splines given velocities and accelerations as further columns,
which leave the positions' path unchanged). For waypoints x_0 ... x_N:

- the inner de Boor points D_1 ... D_{N-1} solve the tridiagonal system
  D_{i-1} + 4 D_i + D_{i+1} = 6 x_i with D_0 = x_0 and D_N = x_N (the "natural"
  end condition of the server's construction); with two segments the server
  solves 4 D_1 = 6 x_1 - x_0 (its last end term is left out), and one segment
  is the two-segment rule's end terms; this module does the same;
- the end control points are E_0 = (2 x_0 + D_1) / 3 and E_N = (D_{N-1} + 2 x_N) / 3;
- segment i runs from x_i to x_{i+1} with inner Bézier points taken from the
  de Boor points around it (thirds inside, halves at the first and last
  segment, the end control point at the ends).

Time enters per segment: at `t` seconds the segment is the one whose waypoint
times bracket `t`, and its Bézier parameter is the share of that segment's
duration elapsed. The path is C1 in that parameter, so the joint velocity jumps
at a waypoint where consecutive segments' durations differ (as on the robot),
and the path may overshoot a waypoint between two others: it leaves the
straight segments between waypoints that a planner checked (see
`app.robot.sim_model`'s motion check and the tests on the collision margin).
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


class BezierSpline:
    """The commanded path of some joints through timed waypoints."""

    def __init__(self, times: Sequence[float], points: Sequence[Sequence[float]]) -> None:
        if len(times) < 2 or len(times) != len(points):
            raise ValueError("a spline needs two or more timed waypoints")
        self.times = [float(t) for t in times]
        x = np.asarray(points, dtype=np.float64)  # waypoints x joints
        self.control = _bezier_points(x)  # segments x 4 x joints

    def at(self, t: float) -> tuple[Array, Array]:
        """Positions and velocities (rad/s) `t` seconds in (the first waypoint
        before the first time, the last one after the last)."""
        k = bisect.bisect_right(self.times, t)
        if k == 0:
            return self.control[0, 0].copy(), np.zeros(self.control.shape[2])
        if k >= len(self.times):
            return self.control[-1, 3].copy(), np.zeros(self.control.shape[2])
        t0, t1 = self.times[k - 1], self.times[k]
        u = min(max((t - t0) / (t1 - t0), 0.0), 1.0)
        b0, b1, b2, b3 = self.control[k - 1]
        v = 1.0 - u
        position = v**3 * b0 + 3 * v * v * u * b1 + 3 * v * u * u * b2 + u**3 * b3
        slope = 3 * (v * v * (b1 - b0) + 2 * v * u * (b2 - b1) + u * u * (b3 - b2))
        return position, slope / (t1 - t0)

    def sample(self, per_segment: int) -> Array:
        """`per_segment` positions per segment and the last waypoint (rows)."""
        rows: list[Array] = []
        for k in range(len(self.times) - 1):
            t0, t1 = self.times[k], self.times[k + 1]
            rows.extend(self.at(t0 + (t1 - t0) * j / per_segment)[0] for j in range(per_segment))
        rows.append(self.control[-1, 3])
        return np.asarray(rows)


def _bezier_points(x: Array) -> Array:
    """Each segment's four Bézier control points, for every joint."""
    n = x.shape[0] - 1  # segments
    d = np.zeros((n + 3, x.shape[1]))
    d[0], d[n + 2] = x[0], x[n]
    if n > 2:
        system = 4.0 * np.eye(n - 1) + np.eye(n - 1, k=1) + np.eye(n - 1, k=-1)
        right = 6.0 * x[1:n]
        right[0] -= x[0]
        right[-1] -= x[n]
        d[2 : n + 1] = np.linalg.solve(system, right)
    else:
        d[2] = (6.0 * x[1] - x[0]) / 4.0
    d[1] = (2.0 * x[0] + d[2]) / 3.0
    d[n + 1] = (d[n] + 2.0 * x[n]) / 3.0
    control = np.zeros((n, 4, x.shape[1]))
    for i in range(n):
        p, q = d[i + 1], d[i + 2]
        if i == 0:
            inner = (p, (p + q) / 2.0)
        elif i == n - 1:
            inner = ((p + q) / 2.0, q)
        else:
            inner = ((2.0 * p + q) / 3.0, (p + 2.0 * q) / 3.0)
        control[i] = (x[i], inner[0], inner[1], x[i + 1])
    return control
