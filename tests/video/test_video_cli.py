"""`peha run --video` end to end (ctest video.cli): an MP4 beside the CSV, and a clear
message, exit code 0 and every other output when no OpenGL context can be made."""
import json
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
E1 = ROOT / "configs" / "e1_one_dof.yaml"


def peha_binary():
    path = os.environ.get("PEHA_BINARY")
    if not path:
        pytest.skip("PEHA_BINARY not set: run through ctest (test video.cli)")
    return path


def test_video_is_written_beside_the_csv(tmp_path):
    r = subprocess.run([peha_binary(), "run", "--config", str(E1), "--case", "payload_2.5kg", "--no-plot", "--video",
                        "--out", str(tmp_path), "--name", "v"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    mp4 = tmp_path / "v" / "e1_payload_2.5kg.mp4"
    assert mp4.exists(), r.stdout + r.stderr
    assert "video: " in r.stdout and "rendered with" in r.stdout
    probe = json.loads(subprocess.run(["ffprobe", "-v", "error", "-select_streams", "v:0", "-show_entries",
                                       "stream=width,height,nb_frames,avg_frame_rate:format=duration", "-of", "json",
                                       str(mp4)], check=True, capture_output=True, text=True).stdout)
    stream = probe["streams"][0]
    assert (stream["width"], stream["height"], stream["avg_frame_rate"]) == (960, 540, "30/1")
    assert int(stream["nb_frames"]) == 1020  # 34 s at 30 fps, 1x
    assert abs(float(probe["format"]["duration"]) - 34.0) < 0.05


def test_without_a_display_server_the_run_says_so_and_writes_everything_else(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    env["PEHA_GL"] = "glfw"             # no EGL: the X path only ...
    env["PATH"] = str(tmp_path / "empty")  # ... and no Xvfb to start
    r = subprocess.run([peha_binary(), "run", "--config", str(E1), "--case", "payload_2.5kg", "--no-plot", "--video",
                        "--out", str(tmp_path), "--name", "nv"], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert "NO VIDEO WRITTEN" in r.stderr and "Xvfb" in r.stderr, r.stderr
    run = tmp_path / "nv"
    for name in ("e1_payload_2.5kg.csv", "summary.csv", "config.yaml"):
        assert (run / name).stat().st_size > 0, name
    assert not list(run.glob("*.mp4"))
