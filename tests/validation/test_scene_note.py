"""A scene's ``note`` is a regular UTF-8 text file of at most 64 KiB, named in the report (item 17).

Before: any readable file was copied into the report (``/proc/self/environ`` included).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from rigval.sample_data import runs_dir
from rigval.validation.errors import SceneError
from rigval.validation.note import MAX_NOTE_BYTES, read_note
from rigval.validation.scene import load_scene

SHIPPED = runs_dir() / "run_0p8_scene.toml"


def _scene(tmp_path: Path, note: str) -> Path:
    text = SHIPPED.read_text()
    text = re.sub(r'^(file|note) = "(run_0p8_[^"]+)"',
                  lambda m: f'{m[1]} = "{(runs_dir() / m[2]).as_posix()}"', text, flags=re.M)
    text = re.sub(r'^note = ".*"$', f'note = "{note}"', text, flags=re.M)
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="needs /proc")
def test_proc_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(SceneError) as info:
        load_scene(_scene(tmp_path, "/proc/self/environ"))
    assert info.value.where["key"] == "note"
    assert "environ" in str(info.value) and info.value.hint


def test_oversized_binary_and_directory_notes_are_refused(tmp_path: Path) -> None:
    big = tmp_path / "big.txt"
    big.write_text("x" * (MAX_NOTE_BYTES + 1))
    binary = tmp_path / "binary.txt"
    binary.write_bytes(b"operator\x00note")
    latin = tmp_path / "latin.txt"
    latin.write_bytes("Bediener: Gr\u00fc\u00dfe".encode("latin-1"))
    for path, words in ((big, "64 KiB"), (binary, "not text"), (latin, "not UTF-8"),
                        (tmp_path, "not a regular file")):
        with pytest.raises(SceneError, match=words) as info:
            read_note(path)
        assert info.value.where == {"key": "note", "file": path}


def test_fifo_is_refused_without_blocking(tmp_path: Path) -> None:
    fifo = tmp_path / "note.fifo"
    os.mkfifo(fifo)
    with pytest.raises(SceneError, match="not a regular file"):
        read_note(fifo)


def test_regular_note_is_read_and_the_report_names_its_file(tmp_path: Path) -> None:
    note = tmp_path / "note.txt"
    text = "Run 7: oil changed before the run.\nGr\u00fc\u00dfe\n" * 100
    note.write_text(text, encoding="utf-8")
    assert read_note(note) == text
    scene = load_scene(_scene(tmp_path, note.as_posix()))
    from rigval.validation.report.run_report import _note_block

    html = _note_block(scene.note, read_note(scene.note))
    assert html is not None and str(note) in html[0] and html[1] == text
