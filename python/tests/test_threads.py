"""Threads: track() releases the GIL, a threaded System does not deadlock beside Python threads, calls on one
System from several threads are serialized, and Systems in different threads give their sequential results."""
import faulthandler
import sys
import threading
import time

import numpy as np
import pytest

import priorslam
from conftest import CONFIG

# A deadlock would otherwise hang until CTest's timeout: dump every thread's stack and end the process instead.
WATCHDOG_SECONDS = 300


@pytest.fixture(autouse=True)
def watchdog():
    faulthandler.dump_traceback_later(WATCHDOG_SECONDS, exit=True)
    yield
    faulthandler.cancel_dump_traceback_later()


def images(clip):
    return [(np.array(f.image), f.timestamp) for f in priorslam.Rawlog(clip.rawlog, channels=[])]


def camera_of(clip):
    c = clip.camera
    return priorslam.Camera(c["fx"], c["fy"], c["cx"], c["cy"], c["width"], c["height"])


def test_threaded_system_beside_python_threads(small_room):
    """Local mapping in its own thread, frames tracked in a Python thread, a second Python thread reading the System's
    state, the main thread watching: every frame is tracked, and the main thread ran while frames were tracked.

    The interpreter's switch interval is made very long, so a thread gives up the GIL only when it blocks: the
    tracking thread then lets the main thread run only if track() releases the GIL (with the GIL held inside track()
    the main thread would never see a frame in progress)."""
    frames = images(small_room)
    slam = priorslam.System(CONFIG, threaded=True, camera=camera_of(small_room))
    assert slam.threaded
    done = threading.Event()
    current = [None]  # the frame index being tracked, None between calls
    seen = set()
    summaries = []

    def track_all():
        try:
            for k, (image, stamp) in enumerate(frames):
                current[0] = k
                slam.track(image, stamp)
                current[0] = None
            slam.finish()
        finally:
            done.set()

    def reader():
        while not done.is_set():
            summaries.append(slam.summary()["frames_processed"])
            slam.trajectory()
            time.sleep(0.001)

    interval = sys.getswitchinterval()
    sys.setswitchinterval(100.0)
    try:
        threads = [threading.Thread(target=track_all), threading.Thread(target=reader)]
        for t in threads:
            t.start()
        while not done.is_set():
            k = current[0]
            if k is not None:
                seen.add(k)
            time.sleep(0.0001)  # blocks: the other threads may take the GIL
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(interval)
    assert slam.summary()["frames_processed"] == len(frames)
    assert slam.summary()["keyframes"] > 0
    assert summaries == sorted(summaries)
    assert seen, "the main thread never ran while a frame was tracked: track() held the GIL"
    slam.close()


def test_systems_in_parallel_threads_give_their_sequential_results(small_room):
    frames = images(small_room)

    def run():
        slam = priorslam.System(CONFIG, camera=camera_of(small_room))
        for image, stamp in frames:
            slam.track(image, stamp)
        return slam.trajectory()

    expected = run()
    results = [None, None]

    def worker(k):
        results[k] = run()

    threads = [threading.Thread(target=worker, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        np.testing.assert_array_equal(r, expected)


def test_one_system_from_two_threads(small_room, tmp_path):
    """While one thread tracks, another saves the map and reads the report of the same System: the calls run one at
    a time (the façade is not meant for concurrent calls), nothing crashes, and the tracking is the same as alone."""
    frames = images(small_room)
    alone = priorslam.System(CONFIG, camera=camera_of(small_room))
    for image, stamp in frames:
        alone.track(image, stamp)
    slam = priorslam.System(CONFIG, camera=camera_of(small_room))
    done = threading.Event()
    saved = []

    def other():
        while not done.is_set():
            slam.save_map(tmp_path / "map.slammap")
            saved.append(len(slam.report()["frames"]))

    t = threading.Thread(target=other)
    t.start()
    try:
        for image, stamp in frames:
            slam.track(image, stamp)
    finally:
        done.set()
        t.join()
    assert saved and saved == sorted(saved)
    np.testing.assert_array_equal(slam.trajectory(), alone.trajectory())


def test_closing_a_threaded_system_while_mapping(small_room):
    frames = images(small_room)
    for _ in range(3):
        slam = priorslam.System(CONFIG, threaded=True, camera=camera_of(small_room))
        for image, stamp in frames[:25]:
            slam.track(image, stamp)
        del slam  # ends the mapping thread with the GIL released, possibly in the middle of a keyframe
