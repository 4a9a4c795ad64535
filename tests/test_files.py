"""Atomic writing: whole files or none, and one clear line for paths that cannot be written."""

from __future__ import annotations

import os

import pytest

from lathe_mirror.errors import InputError
from lathe_mirror.export.files import json_text, write_text


def test_write_is_atomic_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "a.json"
    write_text(target, "one\n")
    write_text(target, "two\n")
    assert target.read_text() == "two\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]


def test_fifo_and_directory_are_refused(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match="not a regular file"):
        write_text(fifo, "x")
    assert fifo.exists() and not fifo.is_file()  # still the FIFO, not replaced
    with pytest.raises(InputError, match="is a directory"):
        write_text(tmp_path, "x")
    with pytest.raises(InputError, match="does not exist"):
        write_text(tmp_path / "nope" / "a.txt", "x")


def test_json_text_has_no_nan_and_plain_types():
    import numpy as np

    text = json_text({"a": float("nan"), "b": np.float64(1.5), "c": np.arange(2), 3: (1, 2)})
    assert text == '{\n  "a": null,\n  "b": 1.5,\n  "c": [\n    0,\n    1\n  ],\n  "3": [\n    1,\n    2\n  ]\n}\n'
