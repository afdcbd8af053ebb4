#!/usr/bin/env python3
"""run_rawlog.py: SLAM on a rawlog from Python, the twin of examples/minimal_slam.cpp (doc/python.md).

    python3 examples/python/run_rawlog.py <config.ini> <in.rawlog> [--out DIR] [--set Section.key=value ...]
                                          [--seed N] [--threaded]

Feeds every frame of the rawlog to priorslam.System, prints one line per frame (index, status and, when the frame
has a pose, the camera position of T_world_cam), then writes trajectory.txt, keyframes.txt and map.slammap into
--out (default: the current folder) and prints a summary. The trajectory files carry slam-run's header lines, so a
sequential run gives the bytes of `slam-run --config <config.ini> --rawlog <in.rawlog>` (compare them with cmp).
"""
import argparse
import os
import sys

import priorslam


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("config", help="MRPT ini file (config/slam/*.ini)")
    parser.add_argument("rawlog", help="input rawlog")
    parser.add_argument("--out", default=".", help="output folder (default: the current one)")
    parser.add_argument("--set", action="append", default=[], metavar="Section.key=value",
                        help="override one ini value (repeatable), as slam-run --set")
    parser.add_argument("--seed", type=int, default=0, help="seed of every random process (default 0)")
    parser.add_argument("--threaded", action="store_true", help="local mapping in a second thread")
    args = parser.parse_args()
    try:
        slam = priorslam.System(args.config, overrides=args.set, seed=args.seed,
                                threaded=True if args.threaded else None)
        # Only the channels the System uses are decoded; frames are read ahead in the reader's thread (as slam-run).
        with priorslam.Rawlog(args.rawlog, channels=slam.channels_used()) as frames:
            for frame in frames:
                r = slam.track_frame(frame)
                if r.pose is not None:
                    x, y, z = r.pose[:3, 3]
                    print(f"{frame.index} {r.state} {x:.6f} {y:.6f} {z:.6f}")
                else:
                    print(f"{frame.index} {r.state}")
        slam.finish()
        os.makedirs(args.out, exist_ok=True)
        slam.save_trajectory(os.path.join(args.out, "trajectory.txt"),
                             comment="slam-run: every tracked frame, T_world_cam")
        slam.save_keyframe_trajectory(os.path.join(args.out, "keyframes.txt"),
                                      comment="slam-run: keyframes, T_world_cam")
        slam.save_map(os.path.join(args.out, "map.slammap"))
        s = slam.summary()
        print(f"summary {s['frames_tracked']} of {s['frames_processed']} frames tracked, {s['keyframes']} keyframes, "
              f"{s['map_points']} map points")
        return 0
    except priorslam.Error as e:
        print(f"run_rawlog.py: error: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
