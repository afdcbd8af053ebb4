"""priorslam.eval on trajectories made in the test: alignment, association and the metrics' definitions."""
import numpy as np
import pytest

import priorslam


def rotation_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def helix(n=60):
    t = np.arange(n) * 0.1
    poses = np.zeros((n, 8))
    poses[:, 0] = 100.0 + t
    poses[:, 1:4] = np.stack([np.cos(t), np.sin(t), 0.2 * t], axis=1)
    # Yaw following the path, as quaternions (x, y, z, w).
    poses[:, 6] = np.sin(t / 2)
    poses[:, 7] = np.cos(t / 2)
    return poses


def transformed(poses, scale, R, t):
    out = poses.copy()
    out[:, 1:4] = scale * poses[:, 1:4] @ R.T + t
    return out


def test_sim3_alignment_recovers_the_transform():
    gt = helix()
    R = rotation_z(0.3)
    # est = (gt - t) / s rotated back: p_gt = s R p_est + t
    est = gt.copy()
    est[:, 1:4] = ((gt[:, 1:4] - [1.0, 2.0, 3.0]) / 2.5) @ R  # R^T applied to rows
    est[:, 4:] = gt[:, 4:]
    r = priorslam.eval.ate(gt, est)
    assert r.alignment.scale == pytest.approx(2.5, rel=1e-9)
    np.testing.assert_allclose(r.alignment.rotation, R, atol=1e-9)
    np.testing.assert_allclose(r.alignment.translation, [1.0, 2.0, 3.0], atol=1e-9)
    assert r.rmse < 1e-9
    np.testing.assert_allclose(r.alignment.matrix[:3, :3], 2.5 * R, atol=1e-9)
    np.testing.assert_allclose(r.est_aligned[:, 1:4], gt[:, 1:4], atol=1e-9)
    # SE(3) cannot absorb the scale.
    assert priorslam.eval.ate(gt, est, align="se3").rmse > 0.1
    assert priorslam.eval.ate(gt, est, align="se3").alignment.scale == 1.0


def test_ate_of_a_known_offset():
    gt = helix()
    est = gt.copy()
    est[::2, 1] += 0.1  # every other pose 10 cm off in x
    r = priorslam.eval.ate(gt, est, align="none")
    expected = np.zeros(len(gt))
    expected[::2] = 0.1
    np.testing.assert_allclose(r.errors, expected, atol=1e-12)
    assert r.rmse == pytest.approx(np.sqrt(np.mean(expected ** 2)), rel=1e-12)
    s = r.stats
    assert s.count == len(gt) and s.max == pytest.approx(0.1) and s.min == pytest.approx(0.0, abs=1e-12)
    assert set(s.to_dict()) == {"rmse", "mean", "median", "std", "min", "max", "sse", "count"}


def test_rpe_of_a_constant_drift():
    gt = helix()
    est = gt.copy()
    est[:, 1] += 0.01 * np.arange(len(gt))  # 1 cm more per frame in x
    r = priorslam.eval.rpe(gt, est, align="none")
    np.testing.assert_allclose(r.translation_errors, 0.01, atol=1e-9)
    assert r.rotation.max < 1e-6
    assert len(r.pairs) == len(gt) - 1
    r5 = priorslam.eval.rpe(gt, est, align="none", delta=5)
    np.testing.assert_allclose(r5.translation_errors, 0.05, atol=1e-9)


def test_association_by_stamps_and_offset():
    gt = helix()
    est = gt[::3].copy()
    est[:, 0] += 0.004  # within max_diff
    gi, ei = priorslam.eval.associate(gt, est)
    np.testing.assert_array_equal(gi, np.arange(0, len(gt), 3))
    np.testing.assert_array_equal(ei, np.arange(len(est)))
    est[:, 0] += 50.0  # past the ground truth's end
    with pytest.raises(priorslam.Error):
        priorslam.eval.associate(gt, est)
    gi, _ = priorslam.eval.associate(gt, est, offset=-50.0)
    assert len(gi) == len(est)


def test_read_trajectory_round_trip(tmp_path):
    gt = helix()
    path = tmp_path / "t.txt"
    np.savetxt(path, gt, fmt="%.9f")
    np.testing.assert_allclose(priorslam.eval.read_trajectory(path), gt, atol=1e-8)
    r = priorslam.eval.ate(path, gt)
    assert r.rmse < 1e-7 and r.association == "nearest"
