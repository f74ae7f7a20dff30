"""A bake's dataset folder: shard processes started side by side each create it, and none fails for it."""
from pathlib import Path

import pytest

from ssgi.model.dataset import folder as dsf
from ssgi.model.errors import UserError


def test_a_folder_another_shard_created_meanwhile_is_reopened(tmp_path, monkeypatch):
    target = tmp_path / "bake"
    real_exists = Path.exists
    seen = []

    def exists_then_created(self):  # the other shard creates it between this one's checks and its mkdir
        if self == target and len(seen) < 2:
            seen.append(True)
            if len(seen) == 2:
                target.mkdir()
            return False
        return real_exists(self)

    monkeypatch.setattr(Path, "exists", exists_then_created)
    m = dsf.prepare_folder(target, {"size": [8, 8]}, "5.0.1", shard=(1, 2))
    assert seen and target.is_dir() and isinstance(m, dict)


def test_a_file_in_the_folders_place_is_refused_in_one_line(tmp_path):
    (tmp_path / "bake").write_text("not a folder")
    with pytest.raises(UserError, match="exists and is not a folder"):
        dsf.prepare_folder(tmp_path / "bake", {"size": [8, 8]}, "5.0.1")
