"""The module against the built tools: the same trajectory bytes as slam-run, the same metrics as slam-eval."""
import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import priorslam
from conftest import CONFIG, SOURCE_DIR, run_tool

pytestmark = pytest.mark.e2e

# The header comments slam-run writes (apps/slam-run/src/SlamRunApp.cpp).
TRAJECTORY_COMMENT = "slam-run: every tracked frame, T_world_cam"
KEYFRAMES_COMMENT = "slam-run: keyframes, T_world_cam"


@pytest.fixture(scope="module")
def slam_run(room, tmp_path_factory):
    """slam-run's outputs on the room clip (sequential, seed 0)."""
    out = tmp_path_factory.mktemp("slam_run")
    run_tool("slam-run", "--config", CONFIG, "--rawlog", room.rawlog, "--out", out, "-q")
    return out


def test_run_rawlog_example_reproduces_slam_run_byte_for_byte(room, slam_run, tmp_path):
    out = tmp_path / "py"
    p = subprocess.run([sys.executable, str(SOURCE_DIR / "examples/python/run_rawlog.py"), str(CONFIG),
                        str(room.rawlog), "--out", str(out)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    assert sum(1 for line in lines if line.split(" ")[0].isdigit()) == 60
    assert lines[-1].startswith("summary ")
    for name in ("trajectory.txt", "keyframes.txt"):
        assert (out / name).read_bytes() == (slam_run / name).read_bytes(), name
    assert (out / "map.slammap").stat().st_size > 0


def test_images_from_numpy_arrays_give_slam_runs_trajectory(room, slam_run, tmp_path):
    c = room.camera
    camera = priorslam.Camera(c["fx"], c["fy"], c["cx"], c["cy"], c["width"], c["height"])
    slam = priorslam.System(CONFIG, camera=camera)
    frames = [(np.array(f.image), f.timestamp) for f in priorslam.Rawlog(room.rawlog, channels=[])]
    states = [slam.track(image, t).state for image, t in frames]
    assert states.count("tracking") > 30
    slam.save_trajectory(tmp_path / "trajectory.txt", comment=TRAJECTORY_COMMENT)
    assert (tmp_path / "trajectory.txt").read_bytes() == (slam_run / "trajectory.txt").read_bytes()
    # The array holds the poses the file was written from (the file has 9 significant digits).
    from_file = priorslam.eval.read_trajectory(slam_run / "trajectory.txt")
    np.testing.assert_allclose(slam.trajectory(), from_file, rtol=0, atol=1e-6)
    summary = slam.summary()
    report = json.loads((slam_run / "report.json").read_text())
    for key in ("frames_processed", "frames_tracked", "keyframes", "map_points", "initialized_at_frame"):
        assert summary[key] == report["summary"][key], key


def _slam_eval_json(gt, est, out, *args):
    run_tool("slam-eval", gt, est, "--json", out, *args)
    return json.loads(pathlib.Path(out).read_text())


@pytest.mark.parametrize("cli_args, kwargs", [
    ((), {}),
    (("--align", "se3", "--association", "tum", "--max-diff", "0.02", "--delta", "5"),
     dict(align="se3", association="tum", max_diff=0.02, delta=5)),
    (("--align", "sim3", "--align-first", "20", "--delta", "0.1", "--delta-unit", "m", "--all-pairs"),
     dict(align="sim3", align_first_n=20, delta=0.1, delta_unit="m", all_pairs=True)),
])
def test_metrics_equal_slam_eval(room, slam_run, tmp_path, cli_args, kwargs):
    est = slam_run / "trajectory.txt"
    expected = _slam_eval_json(room.groundtruth, est, tmp_path / "eval.json", *cli_args)
    rpe_kwargs = {k: v for k, v in kwargs.items()}
    ate_kwargs = {k: v for k, v in kwargs.items() if k not in ("delta", "delta_unit", "all_pairs")}
    gt_array = priorslam.eval.read_trajectory(room.groundtruth)
    est_array = priorslam.eval.read_trajectory(est)
    for gt, e in ((room.groundtruth, est), (str(room.groundtruth), str(est)), (gt_array, est_array)):
        ate = priorslam.eval.ate(gt, e, **ate_kwargs)
        # The same doubles as slam-eval's JSON (17 significant digits), not only the 6 decimals of its table.
        assert ate.stats.to_dict() == expected["ate"]
        assert ate.alignment.scale == expected["alignment"]["scale"]
        assert len(ate.errors) == expected["poses"]["pairs"]
        rpe = priorslam.eval.rpe(gt, e, **rpe_kwargs)
        assert rpe.translation.to_dict() == expected["rpe"]["translation"]
        assert rpe.rotation.to_dict() == expected["rpe"]["rotation_deg"]
        assert len(rpe.pairs) == expected["rpe"]["pairs"]
        gt_index, est_index = priorslam.eval.associate(gt, e, max_diff=kwargs.get("max_diff", 0.01),
                                                       association=kwargs.get("association", "nearest"))
        assert len(gt_index) == len(est_index) == expected["poses"]["pairs"]


def test_metrics_equal_slam_evals_printed_table(room, slam_run):
    est = slam_run / "trajectory.txt"
    table = run_tool("slam-eval", room.groundtruth, est).stdout
    rows = {line[:16].strip(): line[16:].split() for line in table.splitlines() if line[:1] in ("A", "R")}
    ate = priorslam.eval.ate(room.groundtruth, est).stats
    rpe = priorslam.eval.rpe(room.groundtruth, est)
    for name, s in (("ATE [m]", ate), ("RPE t [m]", rpe.translation), ("RPE r [deg]", rpe.rotation)):
        printed = rows[name][:7]
        assert printed == [f"{v:.6f}" for v in (s.rmse, s.mean, s.median, s.std, s.min, s.max)] + [str(s.count)]


def test_image_folder_example_writes_trajectory_and_plot(room, tmp_path):
    cv2 = pytest.importorskip("cv2", reason="python3-opencv (scripts/install-deps.sh)")
    images = tmp_path / "images"
    images.mkdir()
    # Named by their timestamps, as TUM's rgb/ folders: the example stamps each image with its file name.
    for f in priorslam.Rawlog(room.rawlog, channels=[]):
        cv2.imwrite(str(images / f"{f.timestamp:.6f}.png"), f.image)
    c = room.camera
    camera_ini = tmp_path / "camera.ini"
    camera_ini.write_text(f"[CAMERA]\nresolution = [{c['width']} {c['height']}]\nfx = {c['fx']}\nfy = {c['fy']}\n"
                          f"cx = {c['cx']}\ncy = {c['cy']}\ndistortion_model = none\ndist = [0 0 0 0 0]\n")
    out = tmp_path / "out"
    p = subprocess.run([sys.executable, str(SOURCE_DIR / "examples/python/image_folder.py"), str(CONFIG),
                        str(camera_ini), str(images), "--groundtruth", str(room.groundtruth), "--out", str(out)],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    trajectory = priorslam.eval.read_trajectory(out / "trajectory.txt")
    assert len(trajectory) > 40
    assert (out / "trajectory.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    ate_line = [line for line in p.stdout.splitlines() if line.startswith("ATE ")]
    assert ate_line, p.stdout
    assert float(ate_line[0].split()[1]) == pytest.approx(priorslam.eval.ate(room.groundtruth, trajectory).rmse,
                                                          abs=1e-6)
