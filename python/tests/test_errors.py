"""Bad inputs raise priorslam.Error with the one-line message of the C++ tools (minimal_slam, image_folder_slam,
slam-run, slam-eval print it after '<tool>: error: '); the interpreter never goes down."""
import gzip
import os
import shutil

import numpy as np
import pytest

import priorslam
from conftest import CONFIG, run_tool


def cli_error(tool, *args):
    """The message a tool prints after '<tool>: error: ' (it must fail)."""
    p = run_tool(tool, *args, check=False)
    assert p.returncode != 0, p.stdout
    lines = [line for line in p.stderr.splitlines() if line.startswith(f"{tool}: error: ")]
    assert len(lines) == 1, p.stderr
    return lines[0][len(f"{tool}: error: "):]


def raised(call, *args, **kwargs):
    with pytest.raises(priorslam.Error) as info:
        call(*args, **kwargs)
    assert "\n" not in str(info.value)
    return str(info.value)


def test_error_is_a_runtime_error():
    assert issubclass(priorslam.Error, RuntimeError)


@pytest.mark.e2e
@pytest.mark.parametrize("override", ["Tracking.noSuchKey=1", "ORB.nFeatures=-5", "NoSection.key=1", "ORB.nFeatures"])
def test_bad_config_key_or_value(small_room, override):
    message = raised(priorslam.System, CONFIG, overrides=[override])
    assert message == cli_error("slam-run", "--config", CONFIG, "--set", override, "--rawlog", small_room.rawlog,
                                "--out", os.devnull)


@pytest.mark.e2e
def test_bad_key_in_a_config_file(small_room, tmp_path):
    config = tmp_path / "bad.ini"
    config.write_text(CONFIG.read_text().replace("[ORB]", "[ORB]\nnFeaturs = 1000", 1))
    message = raised(priorslam.System, config)
    assert "nFeaturs" in message and str(config) in message
    assert message == cli_error("minimal_slam", config, small_room.rawlog)


@pytest.mark.e2e
def test_missing_files(small_room, tmp_path):
    missing = tmp_path / "missing"
    assert raised(priorslam.System, f"{missing}.ini") == cli_error("minimal_slam", f"{missing}.ini", small_room.rawlog)
    assert raised(priorslam.Rawlog, f"{missing}.rawlog") == cli_error("minimal_slam", CONFIG, f"{missing}.rawlog")
    slam = priorslam.System(CONFIG)
    message = raised(slam.load_map, f"{missing}.slammap")
    assert f"{missing}.slammap" in message
    assert raised(priorslam.Camera.from_ini, f"{missing}.ini").startswith(f"{missing}.ini")


def corrupt_copy(clip, folder, damage):
    """A copy of the clip's rawlog (images shared) with its gzip bytes damaged by damage(bytes) -> bytes."""
    rawlog = folder / "bad.rawlog"
    rawlog.write_bytes(damage(clip.rawlog.read_bytes()))
    os.symlink(clip.rawlog.parent / "room_Images", folder / "bad_Images")
    return rawlog


@pytest.mark.e2e
@pytest.mark.parametrize("damage", [
    lambda b: b[: len(b) // 2],                                            # cut
    lambda b: b[:200] + bytes(x ^ 0x5A for x in b[200:260]) + b[260:],     # flipped bits
    lambda b: gzip.compress(b"not a rawlog at all" * 100),                 # not an archive of observations
], ids=["cut", "flipped", "foreign"])
def test_corrupt_rawlog(small_room, tmp_path, damage):
    rawlog = corrupt_copy(small_room, tmp_path, damage)

    def read_all():
        for _ in priorslam.Rawlog(rawlog):
            pass

    message = raised(read_all)
    assert str(rawlog) in message
    assert message == cli_error("minimal_slam", CONFIG, rawlog)


@pytest.mark.e2e
def test_missing_image_file(small_room, tmp_path):
    images = tmp_path / "bad_Images"
    shutil.copytree(small_room.rawlog.parent / "room_Images", images)
    victim = sorted(images.glob("CAMERA_*"))[5]
    victim.unlink()
    rawlog = tmp_path / "bad.rawlog"
    shutil.copy(small_room.rawlog, rawlog)

    def read_all():
        return [f.index for f in priorslam.Rawlog(rawlog)]

    message = raised(read_all)
    assert victim.name in message
    assert message == cli_error("minimal_slam", CONFIG, rawlog)


@pytest.mark.e2e
def test_wrong_image_size(small_room, tmp_path):
    cv2 = pytest.importorskip("cv2")
    c = small_room.camera
    camera_ini = tmp_path / "camera.ini"
    camera_ini.write_text(f"[CAMERA]\nresolution = [{c['width']} {c['height']}]\nfx = {c['fx']}\nfy = {c['fy']}\n"
                          f"cx = {c['cx']}\ncy = {c['cy']}\ndistortion_model = none\ndist = [0 0 0 0 0]\n")
    folder = tmp_path / "images"
    folder.mkdir()
    image = np.full((100, 120), 128, np.uint8)
    cv2.imwrite(str(folder / "0.png"), image)
    slam = priorslam.System(CONFIG, camera=priorslam.Camera.from_ini(camera_ini))
    message = raised(slam.track, image, 0.0)
    assert message == cli_error("image_folder_slam", CONFIG, camera_ini, folder)
    assert "120x100" in message


def test_bad_images_and_timestamps(small_room):
    c = small_room.camera
    slam = priorslam.System(CONFIG, camera=priorslam.Camera(c["fx"], c["fy"], c["cx"], c["cy"], c["width"], c["height"]))
    shape = (c["height"], c["width"])
    good = np.zeros(shape, np.uint8)
    assert "8-bit" in raised(slam.track, np.zeros(shape, np.float32), 0.0)
    assert "not finite" in raised(slam.track, good, float("nan")) or "NaN" in raised(slam.track, good, float("nan"))
    assert "empty" in raised(slam.track, np.zeros((0, 0), np.uint8), 0.0)
    assert "shape" in raised(slam.track, np.zeros((2, 2, 2, 2), np.uint8), 0.0)
    assert "dtype" in raised(slam.track, np.zeros(shape, np.complex64), 0.0)
    assert "SEMANTIC" in raised(slam.track, good, 0.0, semantic=np.zeros(shape, np.uint8))
    assert "NORMALS" in raised(slam.track, good, 0.0, normals=np.zeros((10, 10, 3), np.uint8))
    # No camera: the images have nothing to be interpreted with.
    assert "no camera" in raised(priorslam.System(CONFIG).track, good, 0.0)
    # The System is still usable after each of them.
    assert slam.track(good, 1.0).state == "initializing"
    with pytest.raises(TypeError):
        slam.track_frame(good)


def test_bad_camera():
    assert "fx" in raised(priorslam.Camera, -1.0, 500.0, 320.0, 240.0, 640, 480)


@pytest.mark.e2e
def test_eval_errors_match_slam_eval(small_room, tmp_path):
    gt = small_room.groundtruth
    missing = tmp_path / "missing.txt"
    assert raised(priorslam.eval.ate, missing, gt) == cli_error("slam-eval", missing, gt)
    assert raised(priorslam.eval.ate, gt, gt, align="sim4") == cli_error("slam-eval", gt, gt, "--align", "sim4")
    assert (raised(priorslam.eval.rpe, gt, gt, association="closest")
            == cli_error("slam-eval", gt, gt, "--association", "closest"))
    bad = tmp_path / "bad.txt"
    bad.write_text("1.0 2.0 3.0\n")
    assert raised(priorslam.eval.ate, gt, bad) == cli_error("slam-eval", gt, bad)
    far = tmp_path / "far.txt"
    far.write_text("".join(f"{1000 + k} 0 0 {k} 0 0 0 1\n" for k in range(5)))
    assert raised(priorslam.eval.ate, gt, far) == cli_error("slam-eval", gt, far)


def test_eval_bad_arrays():
    assert "(N, 8)" in raised(priorslam.eval.ate, np.zeros((5, 7)), np.zeros((5, 8)))
    poses = np.tile([0, 0, 0, 0, 0, 0, 0, 1.0], (5, 1))
    poses[:, 0] = np.arange(5)
    bad = poses.copy()
    bad[2, 4:] = 0
    assert "row 2" in raised(priorslam.eval.ate, poses, bad)
    bad[2, 4:] = [0, 0, 0, np.nan]
    assert "row 2" in raised(priorslam.eval.ate, poses, bad)
    assert "max_diff" in raised(priorslam.eval.ate, poses, poses, max_diff=-1)
