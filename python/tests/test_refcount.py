"""Reference counts over 1,000 track() calls: the arrays handed in are let go, results and errors leak nothing."""
import gc
import sys
import weakref

import numpy as np
import pytest

import priorslam
from conftest import CONFIG

CALLS = 1000


def test_no_reference_leaks_over_1000_track_calls(small_room):
    c = small_room.camera
    camera = priorslam.Camera(c["fx"], c["fy"], c["cx"], c["cy"], c["width"], c["height"])
    rawlog_frames = list(priorslam.Rawlog(small_room.rawlog, channels=["semantic"]))
    kept = [np.array(f.image) for f in rawlog_frames]  # arrays that outlive the run
    semantic = [np.array(f.semantic) for f in rawlog_frames]
    step = rawlog_frames[1].timestamp - rawlog_frames[0].timestamp
    base_kept = [sys.getrefcount(a) for a in kept]
    base_semantic = [sys.getrefcount(a) for a in semantic]

    slam = priorslam.System(CONFIG, camera=camera)
    fresh = []  # weak references to arrays made for one call only
    states = set()
    blocks = None
    for k in range(CALLS):
        j = k % len(kept)
        t = k * step  # the clip again and again: tracking, losing the camera, relocalizing
        if k % 3 == 0:
            image = np.array(kept[j])  # a fresh array, dropped by Python right after the call
            if k < CALLS // 5:  # (before the block count starts: the weak references are blocks too)
                fresh.append(weakref.ref(image))
            r = slam.track(image, t, semantic=semantic[j])
            del image
        elif k % 3 == 1:
            r = slam.track(kept[j], t)
        else:
            r = slam.track(np.asfortranarray(kept[j]), t)  # the copied layout
        states.add(r.state)
        _ = (r.pose, r.state, r.method, r.message)
        del r
        if k == CALLS // 5:
            gc.collect()
            blocks = sys.getallocatedblocks()
    gc.collect()
    growth = sys.getallocatedblocks() - blocks
    assert "tracking" in states
    # Python objects made per call (results, poses, the arrays' references) are all freed: a leak of one object per
    # call would add 800 blocks between the two counts (the mutation of an extra reference per array gave +962).
    print(f"allocated blocks: {growth:+d} over the last {CALLS - CALLS // 5} calls")
    assert growth < 200, growth

    # Errors leak nothing either.
    bad = np.zeros((7, 9), np.uint8)
    base_bad = sys.getrefcount(bad)
    for _ in range(100):
        with pytest.raises(priorslam.Error):
            slam.track(bad, 0.0)
    assert sys.getrefcount(bad) == base_bad

    # Once the System is gone, every array it was given is let go.
    slam.close()
    del slam
    gc.collect()
    assert [sys.getrefcount(a) for a in kept] == base_kept
    assert [sys.getrefcount(a) for a in semantic] == base_semantic
    assert sum(1 for w in fresh if w() is not None) == 0
