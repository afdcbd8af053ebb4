#!/usr/bin/env python3
"""image_folder.py: SLAM on a folder of images read with OpenCV, the trajectory plotted against the ground truth.

    python3 examples/python/image_folder.py <config.ini> <camera.ini> <image-folder> [--fps 30]
                                            [--groundtruth GT.txt] [--out DIR] [--set Section.key=value ...]

<camera.ini>: an MRPT TCamera block in section [CAMERA] (config/cameras/*.ini). The images (PNG or JPEG, grey or
colour) are taken in file-name order; each is stamped with its file name when every name is a number (as in TUM
RGB-D's rgb/ folders), else frame k at k / fps seconds. Writes trajectory.txt (TUM) and trajectory.png into --out:
a top view of the estimate, Sim(3)-aligned to the ground truth with its ATE when --groundtruth (a TUM file) is given.
The Python twin of examples/image_folder_slam.cpp (doc/python.md).
"""
import argparse
import os
import sys

import cv2
import numpy as np

import priorslam

IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg")


def image_stamps(names, fps):
    """The file names as timestamps when all of them are numbers, else k / fps."""
    try:
        return [float(os.path.splitext(n)[0]) for n in names]
    except ValueError:
        return [k / fps for k in range(len(names))]


def plot(path, estimate, groundtruth=None, title=""):
    import matplotlib
    matplotlib.use("Agg")  # files only, no display
    import matplotlib.pyplot as plt

    # The two world axes along which the reference spreads most (as slam-eval's top view).
    reference = groundtruth if groundtruth is not None else estimate
    a0, a1 = sorted(np.argsort(reference[:, 1:4].var(axis=0))[1:])
    axis = "xyz"
    fig, ax = plt.subplots(figsize=(7, 6))
    if groundtruth is not None:
        ax.plot(groundtruth[:, 1 + a0], groundtruth[:, 1 + a1], color="0.6", lw=2, label="ground truth")
    ax.plot(estimate[:, 1 + a0], estimate[:, 1 + a1], color="k", lw=1, label="estimate")
    ax.set_xlabel(f"{axis[a0]} [m]")
    ax.set_ylabel(f"{axis[a1]} [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("config", help="MRPT ini file (config/slam/*.ini)")
    parser.add_argument("camera", help="ini file with the camera in section [CAMERA]")
    parser.add_argument("folder", help="folder of PNG or JPEG images")
    parser.add_argument("--fps", type=float, default=30.0, help="frame rate when the names are not timestamps")
    parser.add_argument("--groundtruth", help="TUM ground truth: the plot shows it and the aligned estimate (ATE)")
    parser.add_argument("--out", default=".", help="output folder (default: the current one)")
    parser.add_argument("--set", action="append", default=[], metavar="Section.key=value",
                        help="override one ini value (repeatable)")
    args = parser.parse_args()
    try:
        if not args.fps > 0:
            raise priorslam.Error(f"--fps {args.fps}: must be > 0")
        if not os.path.isdir(args.folder):
            raise priorslam.Error(f"{args.folder}: image folder not found")
        names = sorted(n for n in os.listdir(args.folder) if n.lower().endswith(IMAGE_EXTENSIONS))
        if not names:
            raise priorslam.Error(f"{args.folder}: no PNG or JPEG image")
        stamps = image_stamps(names, args.fps)

        slam = priorslam.System(args.config, overrides=args.set, camera=priorslam.Camera.from_ini(args.camera))
        for k, (name, t) in enumerate(zip(names, stamps)):
            path = os.path.join(args.folder, name)
            image = cv2.imread(path, cv2.IMREAD_UNCHANGED)
            if image is None:
                raise priorslam.Error(f"{path}: not a readable image")
            if image.ndim == 3 and image.shape[2] == 4:
                image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
            r = slam.track(image, t)  # the array is used in place: no copy into the library
            line = f"{k} {r.state}"
            if r.pose is not None:
                line += " {:.6f} {:.6f} {:.6f}".format(*r.pose[:3, 3])
            print(line)
        slam.finish()

        os.makedirs(args.out, exist_ok=True)
        slam.save_trajectory(os.path.join(args.out, "trajectory.txt"))
        estimate = slam.trajectory()
        s = slam.summary()
        print(f"summary {s['frames_tracked']} of {s['frames_processed']} frames tracked, {s['keyframes']} keyframes")
        png = os.path.join(args.out, "trajectory.png")
        if len(estimate) == 0:
            print("no pose: nothing to plot", file=sys.stderr)
        elif args.groundtruth:
            ate = priorslam.eval.ate(args.groundtruth, estimate)  # Sim(3) alignment: monocular runs have no scale
            print(f"ATE {ate.rmse:.6f} m (sim3, {ate.stats.count} pairs, scale {ate.alignment.scale:.6f})")
            plot(png, ate.est_aligned, ate.gt_associated, f"ATE {ate.rmse:.3f} m (Sim(3) aligned)")
        else:
            plot(png, estimate, None, "estimate (map frame, monocular scale)")
        return 0
    except priorslam.Error as e:
        print(f"image_folder.py: error: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
