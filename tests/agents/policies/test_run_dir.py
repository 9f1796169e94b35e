"""The run directory of a trained agent (agents/policies/run_dir.py): the files' names, the YAML
its writers produce (what python -m train has always written, byte for byte) and its readers'
refusals."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from agents.policies import run_dir

pytestmark = pytest.mark.smoke


def test_the_file_names_of_a_run_directory():
    """The names every run directory and shipped agent already holds (agents/trained/*/)."""
    assert (run_dir.CONFIG_FILE, run_dir.VERSIONS_FILE, run_dir.TRAINING_FILE) == (
        "config.yaml", "versions.yaml", "training.yaml")
    assert (run_dir.MODEL_FILE, run_dir.BEST_MODEL_FILE, run_dir.BEST_TRACKING_MODEL_FILE) == (
        "model.zip", "best_model.zip", "best_tracking_model.zip")
    assert (run_dir.NORMALIZATION_FILE, run_dir.BEST_NORMALIZATION_FILE) == (
        "vecnormalize.pkl", "best_vecnormalize.pkl")
    assert (run_dir.REPLAY_BUFFER_FILE, run_dir.CHECKPOINTS_DIR, run_dir.EVALUATION_FILE,
            run_dir.SOURCE_FILE) == ("replay_buffer.pkl", "checkpoints", "evaluation.yaml",
                                     "source.txt")
    shipped = Path(run_dir.__file__).resolve().parents[1] / "trained"
    for agent in (path for path in shipped.iterdir() if (path / "model.zip").is_file()):
        for name in (run_dir.CONFIG_FILE, run_dir.TRAINING_FILE, run_dir.VERSIONS_FILE):
            assert (agent / name).is_file(), (agent.name, name)


@pytest.mark.parametrize("model, statistics", [
    ("model.zip", "vecnormalize.pkl"), ("best_model.zip", "best_vecnormalize.pkl"),
    ("best_tracking_model.zip", "best_tracking_vecnormalize.pkl"),
    ("checkpoints/sac_5000_steps.zip", "checkpoints/sac_vecnormalize_5000_steps.pkl")])
def test_each_model_has_its_statistics_beside_it(model, statistics):
    assert run_dir.normalization_file(Path("run") / model) == Path("run") / statistics


def test_the_writers_write_what_the_readers_read_back(tmp_path):
    config = {"request": {"algo": "sac"}, "algo": "sac", "env_id": "SoftArmTrackWang2023-v0",
              "env_kwargs": {"preset": "wang2023", "feedback": "em"}, "seed": 0}
    run_dir.write_run_config(tmp_path, config)
    assert (tmp_path / "config.yaml").read_text() == yaml.safe_dump(config, sort_keys=False)
    assert run_dir.read_run_config(tmp_path / "config.yaml") == config
    run_dir.write_versions(tmp_path, {"python": "3.11.0", "numpy": "1.26"})
    assert (tmp_path / "versions.yaml").read_text() == "python: 3.11.0\nnumpy: '1.26'\n"
    first = [{"timesteps": 1000, "wall_s": 2.5, "trained_agent": "em_agent"}]
    run_dir.write_training_segments(tmp_path, first)
    run_dir.append_training_segment(tmp_path, {"timesteps": 500, "wall_s": 1.0})
    both = first + [{"timesteps": 500, "wall_s": 1.0}]
    assert (tmp_path / "training.yaml").read_text() == yaml.safe_dump(both, sort_keys=False)
    assert run_dir.read_training_segments(tmp_path) == both
    assert run_dir.read_training_segments(tmp_path / "missing") is None


def test_a_checkpoint_reads_the_config_of_its_run(tmp_path):
    (tmp_path / "checkpoints").mkdir()
    checkpoint = tmp_path / "checkpoints" / "sac_100_steps.zip"
    assert run_dir.run_config_file(checkpoint) is None
    run_dir.write_run_config(tmp_path, {"algo": "sac"})
    assert run_dir.run_config_file(checkpoint) == tmp_path / "config.yaml"
    assert run_dir.run_directory(checkpoint) == tmp_path
    assert not run_dir.has_normalization_files(checkpoint)
    (tmp_path / "vecnormalize.pkl").write_bytes(b"")
    assert run_dir.has_normalization_files(checkpoint)


def test_the_readers_refuse_a_damaged_file_naming_it(tmp_path):
    assert run_dir.read_run_config(None) == {}
    path = tmp_path / "config.yaml"
    path.write_text("[unclosed")
    with pytest.raises(ValueError, match="config.yaml' is not readable YAML"):
        run_dir.read_run_config(path)
    path.write_text("- a list\n")
    with pytest.raises(ValueError, match="must hold a mapping"):
        run_dir.read_run_config(path)
    path.write_text("env_kwargs: 3\n")
    with pytest.raises(ValueError, match="env_kwargs must be a mapping"):
        run_dir.read_run_config(path)
    (tmp_path / "training.yaml").write_text("- wall_s: 1.0\n")
    with pytest.raises(ValueError, match="training.yaml' must be a list of training segments"):
        run_dir.read_training_segments(tmp_path)
