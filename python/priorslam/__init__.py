"""priorslam: monocular SLAM with semantic and geometric priors, from Python.

The C++ library's System facade, its rawlog reader and the evaluation metrics of slam-eval (doc/python.md)::

    import priorslam
    slam = priorslam.System("config/slam/synthetic.ini")
    for frame in priorslam.Rawlog("room.rawlog", channels=slam.channels_used()):
        r = slam.track_frame(frame)          # or slam.track(image, timestamp) with camera=priorslam.Camera(...)
        if r.pose is not None:
            print(frame.index, r.state, r.pose[:3, 3])
    slam.save_trajectory("trajectory.txt")
    print(priorslam.eval.ate("room_groundtruth.txt", slam.trajectory()).rmse)

Errors of the library raise priorslam.Error with the one-line message the command-line tools print.
"""
from ._core import (  # noqa: F401
    Camera,
    Error,
    Frame,
    FrameResult,
    Rawlog,
    System,
    __version__,
)
from . import eval  # noqa: F401

__all__ = ["Camera", "Error", "Frame", "FrameResult", "Rawlog", "System", "eval", "__version__"]
