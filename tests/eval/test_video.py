"""Videos of runs: the writer (MP4, GIF fallback, refusals), the runners' frames and flags, and
physics that does not notice a video being made."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from eval import video as video_module
from eval.video import EpisodeVideo, VideoWriter, read_video, write_video

SIZE = (96, 72)


def _frames(n: int, shape=(45, 61, 3)) -> list[np.ndarray]:
    return [np.full(shape, 20 * k, np.uint8) for k in range(n)]


def test_mp4_holds_every_frame_at_the_frame_rate(tmp_path):
    """An MP4 (odd sizes padded by one pixel) decoding to the frames written, at ``fps``."""
    import imageio.v2 as imageio

    path = write_video(tmp_path / "run.mp4", _frames(9), fps=20.0)
    assert path == tmp_path / "run.mp4" and path.stat().st_size > 0
    frames = read_video(path)
    assert frames.shape == (9, 46, 62, 3)
    np.testing.assert_allclose(frames[:, :45, :61].mean(axis=(1, 2, 3)), 20 * np.arange(9),
                               atol=3)
    reader = imageio.get_reader(path, format="FFMPEG")
    assert reader.get_meta_data()["fps"] == pytest.approx(20.0)
    reader.close()


def test_gif_where_ffmpeg_is_absent(tmp_path, monkeypatch):
    monkeypatch.setattr(video_module, "ffmpeg_available", lambda: False)
    path = write_video(tmp_path / "run.mp4", _frames(5), fps=10.0)
    assert path == tmp_path / "run.gif"
    frames = read_video(path)
    assert frames.shape == (5, 45, 61, 3)
    np.testing.assert_array_equal(frames[:, 0, 0, 0], 20 * np.arange(5))


@pytest.mark.smoke
def test_writer_refuses_no_frames_mixed_shapes_and_bad_input(tmp_path):
    with pytest.raises(ValueError, match="no frames"):
        write_video(tmp_path / "empty.mp4", [], fps=20.0)
    with pytest.raises(ValueError, match="no frames"):
        with VideoWriter(tmp_path / "empty2.mp4", fps=20.0):
            pass
    with pytest.raises(ValueError, match="first frame's shape"):
        write_video(tmp_path / "mixed.mp4", _frames(2) + _frames(1, (44, 61, 3)), fps=20.0)
    with pytest.raises(ValueError, match="uint8"):
        write_video(tmp_path / "float.mp4", [np.zeros((8, 8, 3))], fps=20.0)
    for fps in (0.0, -5.0, float("nan"), "fast"):
        with pytest.raises(ValueError, match="fps"):
            VideoWriter(tmp_path / "bad.mp4", fps=fps)


def _reach_run(video_path=None, panels=None):
    from agents.policies import make_policy
    from agents.rollout import run_episode

    env = gym.make("SoftArmReach-v0", preset="wang2023", feedback="fused",
                   faults={"name": "low_light", "strength": 0.5}, episode_steps=6,
                   render_size=SIZE)
    policy = make_policy("cc_model", env=env, kp=0.06)
    frames = None if video_path is None else EpisodeVideo(env, video_path, panels)
    record = run_episode(env, policy, seed=2, frames=frames)
    fps = env.unwrapped.metadata["render_fps"]
    env.close()
    return record, fps


def test_run_episode_video_has_a_frame_per_step_and_leaves_the_record_alone(tmp_path):
    """One frame after reset and one per step, scene and camera side by side; the record, the
    camera, F-emp and fused estimates included, is bit-identical to a run without a video."""
    plain, _ = _reach_run()
    assert {"camera", "femp", "fused", "reprojection_error_px"} <= set(plain)
    filmed, fps = _reach_run(tmp_path / "run.mp4")
    assert fps == 20.0
    for key in plain:
        np.testing.assert_array_equal(plain[key], filmed[key], err_msg=key)
    frames = read_video(tmp_path / "run.mp4")
    # the eye-in-hand frame (4:3) at the scene's height beside the scene
    assert frames.shape == (len(plain["time_s"]) + 1, SIZE[1], SIZE[0] + 96, 3)
    _reach_run(tmp_path / "scene.mp4", panels=("scene",))
    assert read_video(tmp_path / "scene.mp4").shape[1:] == (SIZE[1], SIZE[0], 3)


def test_run_config_passes_its_video_path_through_spawned_workers(tmp_path):
    """``RunConfig.video_path`` works in ``run_many``'s spawn workers."""
    from eval.runner import RunConfig, run_many

    configs = [RunConfig(policy="cc_model", policy_params={"kp": 0.06}, env_id="SoftArmReach-v0",
                         env_kwargs={"preset": "wang2023", "feedback": "ground_truth",
                                     "episode_steps": 3, "render_size": SIZE},
                         seed=seed, video_path=str(tmp_path / f"run{seed}.mp4"))
               for seed in (0, 1)]
    records = run_many(configs, workers=2)
    for seed, record in zip((0, 1), records):
        assert read_video(tmp_path / f"run{seed}.mp4").shape == (len(record["time_s"]) + 1,
                                                                  SIZE[1], SIZE[0], 3)
    assert "video_path" not in configs[0].identity()


class _Stop(Exception):
    pass


@pytest.mark.parametrize("command", ["track", "benchmark", "compare"])
def test_video_flag_puts_an_mp4_path_next_to_each_csv(command, tmp_path, monkeypatch):
    """``--video`` gives every run a video path beside its CSV (``<label>.mp4``); without it
    none."""
    import eval.runner
    from eval.__main__ import main

    seen = []

    def fake_run_many(configs, workers=1, progress=False, on_result=None):
        seen.append(configs)
        raise _Stop

    monkeypatch.setattr(eval.runner, "run_many", fake_run_many)
    out = tmp_path / command
    extra = {"track": ["--policies", "cc_model", "--kp", "0.04", "0.1", "--seeds", "3"],
             "benchmark": [],
             "compare": ["--policies", "cc_model", "--paths", "circle", "--conditions",
                         "nominal", "--seeds", "5"]}[command]
    for flag in ([], ["--video"]):
        with pytest.raises(_Stop):
            main([command, "--out", str(out), "--workers", "1", *extra, *flag])
    without, with_video = seen
    assert all(config.video_path is None for config in without)
    paths = [config.video_path for config in with_video]
    expected = {"track": [out / "cc_model_kp0.04_seed3.mp4", out / "cc_model_kp0.1_seed3.mp4"],
                "compare": [out / "runs" / "cc_model_circle_nominal_seed5.mp4"]}
    if command in expected:
        assert paths == [str(path) for path in expected[command]]
    else:
        assert len(paths) >= 2 and all(path.endswith("_seed0.mp4") for path in paths)
        assert str(out / "cc_model_kp0.06_seed0.mp4") in paths


def test_estimation_video(tmp_path):
    """``run_experiments(video=True)`` writes ``<experiment>.mp4`` beside the CSV: the scene and
    the eye-in-hand frame with the estimates, one frame after reset and one per step."""
    from eval.papers.wang2023.estimation import run_estimation

    record = run_estimation("lighting", steps=4, progress=False,
                            video_path=tmp_path / "lighting.mp4")
    frames = read_video(tmp_path / "lighting.mp4")
    assert frames.shape == (len(record["time_s"]) + 1, 240, 640, 3)


def test_estimation_video_flag(tmp_path, monkeypatch):
    import eval.__main__ as cli
    import eval.papers.wang2023.estimation_command as paper_estimation

    calls = []
    monkeypatch.setattr(paper_estimation, "run_experiments",
                        lambda *args, **kwargs: calls.append(kwargs) or [{"experiment": "clean"}])
    cli.main(["estimation", "--steps", "600", "--out", str(tmp_path), "--video"])
    cli.main(["estimation", "--steps", "600", "--out", str(tmp_path)])
    assert [call.get("video", False) for call in calls] == [True, False]


@pytest.mark.slow  # about 16 s; the wang2023 video runs by default
def test_stereo_run_records_and_films(tmp_path):
    """A zou2022 stereo-feedback run keeps its numeric estimates (the SOM nodes and the reasons
    are left out of the record) and films the stereo pair beside the scene."""
    from agents.policies import make_policy
    from agents.rollout import run_episode

    env = gym.make("SoftArmReach-v0", preset="zou2022", feedback="stereo", episode_steps=2,
                   render_size=SIZE)
    policy = make_policy("cc_model", env=env, kp=0.06)
    record = run_episode(env, policy, seed=0,
                         frames=EpisodeVideo(env, tmp_path / "stereo.mp4", None))
    env.close()
    assert "lost" in record and "som_px" not in record and "reason" not in record
    frames = read_video(tmp_path / "stereo.mp4")
    assert frames.shape[:3] == (3, SIZE[1], SIZE[0] + 2 * 128)
