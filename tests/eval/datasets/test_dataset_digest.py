"""The digests of a dataset's data files: recorded when it is written, checked on every load
(soft_gym.datasets.store.load_dataset, the papers' readers, the command lines that read one),
so a data file changed after it was written is one ValueError naming it."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

import soft_gym  # noqa: F401 - registers the ids
from eval.datasets import load_dataset, write_paper_dataset
from soft_gym.datasets.digest import DIGEST_KEY, data_digests
from soft_gym.datasets.store import FORMAT_VERSION, dataset_info
from soft_gym.datasets.training import paper_episode
from tests.cli_errors import assert_one_line_error

PAPER = "zhao2021"
SIZE = {"n_free": 16, "n_loaded": 8}


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> tuple[Path, str]:
    """A small zhao2021 dataset: its root and id."""
    root = tmp_path_factory.mktemp("datasets")
    result = write_paper_dataset(PAPER, root=root, size=SIZE, progress=False, use_cache=False)
    return root, result.dataset_id


def _copy(written: tuple[Path, str], tmp_path: Path) -> tuple[Path, Path]:
    """A copy of the written dataset under ``tmp_path``: its root and ``data/`` directory."""
    root, dataset_id = written
    shutil.copytree(root / dataset_id, tmp_path / dataset_id)
    return tmp_path, tmp_path / dataset_id / "data"


def _episode_file(data: Path) -> Path:
    return next((data / "0").glob("*.arrow"))


def _overwrite_middle(path: Path, n_bytes: int = 2000) -> None:
    """``n_bytes`` bytes in the middle of ``path`` replaced by 0x7f (the file keeps its size)."""
    content = bytearray(path.read_bytes())
    start = len(content) // 2 - n_bytes // 2
    content[start:start + n_bytes] = b"\x7f" * n_bytes
    path.write_bytes(bytes(content))


def _metadata(data: Path) -> tuple[dict, dict]:
    metadata = json.loads((data / "metadata.json").read_text())
    return metadata, json.loads(metadata["soft_arm_gym"])


def _save_metadata(data: Path, metadata: dict, info: dict) -> None:
    metadata["soft_arm_gym"] = json.dumps(info)
    (data / "metadata.json").write_text(json.dumps(metadata))


def test_an_untouched_dataset_loads_with_its_digests(written):
    root, dataset_id = written
    dataset = load_dataset(dataset_id, root=root)
    info = dataset_info(dataset)
    data = root / dataset_id / "data"
    assert info["format"] == FORMAT_VERSION
    assert info[DIGEST_KEY] == data_digests(data)
    assert set(info[DIGEST_KEY]) == {"0/metadata.json", _episode_file(data).relative_to(
        data).as_posix()}


def test_2000_overwritten_bytes_are_one_value_error_naming_the_file(written, tmp_path):
    root, data = _copy(written, tmp_path)
    episode_file = _episode_file(data)
    _overwrite_middle(episode_file)
    with pytest.raises(ValueError, match="was changed after it was written") as error:
        load_dataset(written[1], root=root)
    message = str(error.value)
    assert written[1] in message and str(episode_file) in message
    assert "sha256" in message and "--papers zhao2021 --force" in message


def test_a_truncated_file_is_refused(written, tmp_path):
    root, data = _copy(written, tmp_path)
    episode_file = _episode_file(data)
    episode_file.write_bytes(episode_file.read_bytes()[:-2000])
    with pytest.raises(ValueError, match="changed after it was written") as error:
        load_dataset(written[1], root=root)
    assert str(episode_file) in str(error.value)


@pytest.mark.parametrize("change, words", [
    (lambda data: (data / "0" / "metadata.json").unlink(), "was deleted"),
    (lambda data: (data / "0" / "extra.arrow").write_bytes(b"x"), "was added"),
])
def test_a_deleted_or_added_data_file_is_refused(written, tmp_path, change, words):
    root, data = _copy(written, tmp_path)
    change(data)
    with pytest.raises(ValueError, match=words) as error:
        load_dataset(written[1], root=root)
    assert written[1] in str(error.value) and str(data / "0") in str(error.value)


def test_a_dataset_of_the_digest_layout_without_digests_is_refused(written, tmp_path):
    root, data = _copy(written, tmp_path)
    metadata, info = _metadata(data)
    del info[DIGEST_KEY]
    _save_metadata(data, metadata, info)
    with pytest.raises(ValueError, match="records no valid digest") as error:
        load_dataset(written[1], root=root)
    assert written[1] in str(error.value) and "--force" in str(error.value)


def test_a_dataset_written_before_digests_still_loads(written, tmp_path):
    """Layout version 1 (before digests) records none: it loads, unchecked."""
    root, data = _copy(written, tmp_path)
    metadata, info = _metadata(data)
    del info[DIGEST_KEY]
    _save_metadata(data, metadata, {**info, "format": 1})
    assert load_dataset(written[1], root=root).total_steps == 24


def test_the_readers_refuse_a_changed_file(written, tmp_path):
    root, data = _copy(written, tmp_path)
    _overwrite_middle(_episode_file(data))
    with pytest.raises(ValueError, match="changed after it was written") as error:
        paper_episode(written[1], root, PAPER, {})
    assert str(_episode_file(data)) in str(error.value)


def test_the_training_command_line_reports_a_changed_file_in_one_line(written, tmp_path,
                                                                       capsys, monkeypatch):
    from train.__main__ import main as train_main

    root, data = _copy(written, tmp_path)
    _overwrite_middle(_episode_file(data))
    monkeypatch.setattr("train.trainer.train", lambda request: pytest.fail("trained"))
    line = assert_one_line_error(
        train_main, ["--demo-dataset", written[1], "--demo-root", str(root),
                     "--out", str(tmp_path / "out")], "--demo-dataset", capsys,
        out=tmp_path / "out", also="changed after it was written")
    assert str(_episode_file(data)) in line
