"""Trajectory metrics with slam-eval's functions and defaults (doc/eval.md, doc/python.md).

Trajectories are TUM / KITTI / EuRoC files (the format is detected as slam-eval detects it) or (N, 8) arrays of
t, x, y, z, qx, qy, qz, qw (T_world_cam), e.g. System.trajectory(). The defaults are slam-eval's: evo's nearest-stamp
association with max_diff 0.01 s and a Sim(3) alignment (monocular runs have no scale)::

    r = priorslam.eval.ate("room_groundtruth.txt", "out/trajectory.txt")            # = slam-eval's ATE row
    print(r.rmse, r.stats.median, r.alignment.scale)
    p = priorslam.eval.rpe(gt_array, est_array, align="se3", delta=10)
"""
from ._core import eval as _eval  # a submodule of the extension, not importable by its dotted name

Alignment = _eval.Alignment
AteResult = _eval.AteResult
RpeResult = _eval.RpeResult
Statistics = _eval.Statistics
associate = _eval.associate
ate = _eval.ate
read_trajectory = _eval.read_trajectory
rpe = _eval.rpe

__all__ = ["Alignment", "AteResult", "RpeResult", "Statistics", "associate", "ate", "read_trajectory", "rpe"]
