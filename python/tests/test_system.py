"""priorslam.System, Rawlog and Frame on a small rendered clip: what each call returns."""
import re
import sys

import numpy as np
import pytest

import priorslam
from conftest import CONFIG


def camera_of(clip):
    c = clip.camera
    return priorslam.Camera(c["fx"], c["fy"], c["cx"], c["cy"], c["width"], c["height"])


def run(clip, **kwargs):
    slam = priorslam.System(CONFIG, **kwargs)
    results = [slam.track_frame(f) for f in priorslam.Rawlog(clip.rawlog, channels=slam.channels_used())]
    return slam, results


@pytest.fixture(scope="module")
def tracked(small_room):
    return run(small_room)


def test_version():
    assert priorslam.__version__.count(".") == 2


def test_rawlog_frames(small_room):
    frames = list(priorslam.Rawlog(small_room.rawlog))
    assert [f.index for f in frames] == list(range(40))
    assert priorslam.Rawlog.count_frames(small_room.rawlog) == 40
    assert all(b.timestamp > a.timestamp for a, b in zip(frames, frames[1:]))
    f = frames[3]
    assert f.image.dtype == np.uint8 and f.image.shape[:2] == (240, 320)
    assert f.camera == camera_of(small_room)
    assert f.sensor_pose.shape == (4, 4)
    # The rendered room has every channel; the arrays share the frame's pixels and cannot be written.
    assert f.depth.dtype == np.uint16 and f.depth.shape == (240, 320) and f.depth_units > 0
    assert f.semantic.shape == (240, 320, 3) and f.normals.shape == (240, 320, 3)
    assert not f.image.flags.writeable
    assert "index=3" in repr(f)


def test_rawlog_decodes_only_the_channels_asked_for(small_room):
    f = next(iter(priorslam.Rawlog(small_room.rawlog, channels=["semantic"], prefetch=0)))
    assert f.depth is None and f.normals is None and f.semantic is not None


def test_frame_arrays_outlive_the_frame_and_the_rawlog(small_room):
    reader = priorslam.Rawlog(small_room.rawlog)
    image = next(reader).image
    expected = image.copy()
    del reader
    assert np.array_equal(image, expected)


def test_track_results(tracked, small_room):
    slam, results = tracked
    assert [r.index for r in results] == list(range(40))
    assert {r.state for r in results} <= {"initializing", "tracking", "lost", "relocalized"}
    assert results[-1].state == "tracking"
    assert any(r.keyframe for r in results)
    for r in results:
        assert (r.pose is not None) == r.tracked
        if r.pose is not None:
            R = r.pose[:3, :3]
            np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-9)
            np.testing.assert_array_equal(r.pose[3], [0, 0, 0, 1])
    assert results[-1].keyframes > 0 and results[-1].map_points > 0
    assert "state='tracking'" in repr(results[-1])


def test_trajectories_and_summary(tracked):
    slam, results = tracked
    trajectory = slam.trajectory()
    assert trajectory.shape[1] == 8 and trajectory.dtype == np.float64
    summary = slam.summary()
    assert summary["frames_processed"] == 40
    assert len(trajectory) == summary["frames_tracked"] + 1  # + the initializing frame, which has a pose
    np.testing.assert_allclose(np.linalg.norm(trajectory[:, 4:], axis=1), 1.0, atol=1e-12)
    last = results[-1].pose
    assert trajectory[-1, 0] == results[-1].timestamp
    keyframes = slam.keyframe_trajectory()
    assert len(keyframes) == summary["keyframes"] == results[-1].keyframes
    assert summary["initialized_at_frame"] >= 0
    assert np.linalg.norm(trajectory[-1, 1:4] - last[:3, 3]) < 0.1  # refined by local BA since, but close


def test_report_timings_and_properties(tracked, small_room):
    slam, _ = tracked
    report = slam.report()
    assert len(report["frames"]) == 40 and report["seed"] == 0
    assert "extraction" in slam.timings()
    assert slam.initialized and slam.mapping_enabled and not slam.threaded and slam.seed == 0
    assert slam.camera == camera_of(small_room)
    assert set(slam.channels_used()) <= {"semantic", "normals"}


def test_same_seed_same_bytes(small_room, tracked, tmp_path):
    slam, _ = tracked
    again, _ = run(small_room)
    slam.save_trajectory(tmp_path / "a.txt")
    again.save_trajectory(tmp_path / "b.txt")
    assert (tmp_path / "a.txt").read_bytes() == (tmp_path / "b.txt").read_bytes()
    again.save_trajectory(tmp_path / "c.txt", comment="a comment")
    assert (tmp_path / "c.txt").read_text().startswith("# a comment\n")


def test_overrides_and_seed(small_room):
    slam = priorslam.System(CONFIG, overrides={"ORB.nFeatures": 500, "System.threaded": False}, seed=3)
    assert re.search(r"\bnFeatures\s*=\s*500\b", slam.report()["config"])
    assert slam.seed == 3
    listed = priorslam.System(CONFIG, overrides=["ORB.nFeatures=400"])
    assert re.search(r"\bnFeatures\s*=\s*400\b", listed.report()["config"])


def test_save_and_load_map_then_localize(tracked, small_room, tmp_path):
    slam, _ = tracked
    slam.save_map(tmp_path / "map.slammap")
    keyframes = slam.summary()["keyframes"]
    other = priorslam.System(CONFIG, camera=camera_of(small_room))
    other.load_map(tmp_path / "map.slammap")
    other.set_mapping_enabled(False)
    assert not other.mapping_enabled
    states = [other.track(f.image, f.timestamp).state for f in priorslam.Rawlog(small_room.rawlog, channels=[])]
    assert "relocalized" in states
    assert other.summary()["keyframes"] == keyframes  # localization only: the map did not change


def test_reset_discards_map_and_trajectory(small_room):
    slam, _ = run(small_room)
    slam.reset()
    assert len(slam.trajectory()) == 0 and len(slam.keyframe_trajectory()) == 0
    assert not slam.initialized


def test_numpy_layouts(small_room):
    """C-contiguous rows are used in place, other layouts are copied once; both track the same."""
    frames = [(np.array(f.image), f.timestamp) for f in priorslam.Rawlog(small_room.rawlog, channels=[])][:20]
    a = priorslam.System(CONFIG, camera=camera_of(small_room))
    b = priorslam.System(CONFIG, camera=camera_of(small_room))
    for image, t in frames:
        ra = a.track(image, t)
        rb = b.track(np.asfortranarray(image), t)
        assert ra.state == rb.state
    np.testing.assert_array_equal(a.trajectory(), b.trajectory())


def test_image_in_place_stays_referenced_while_the_library_holds_it(small_room):
    """No copy: the library's Mat holds the array itself (here as the tracker's last frame) until it lets go."""
    frames = [(np.array(f.image), f.timestamp) for f in priorslam.Rawlog(small_room.rawlog, channels=[])][:3]
    image = frames[0][0]
    if image.ndim == 3:
        pytest.skip("colour frames are converted to grey by the library, which then keeps its own copy")
    before = sys.getrefcount(image)
    slam = priorslam.System(CONFIG, camera=camera_of(small_room))
    slam.track(image, frames[0][1])
    assert sys.getrefcount(image) > before
    slam.close()
    assert sys.getrefcount(image) == before
    with pytest.raises(priorslam.Error, match="closed"):
        slam.summary()


def test_docstrings():
    for obj in (priorslam.System, priorslam.System.track, priorslam.System.track_frame, priorslam.Rawlog,
                priorslam.eval.ate, priorslam.eval.rpe, priorslam.eval.associate, priorslam.Error):
        assert obj.__doc__ and len(obj.__doc__) > 30, obj
