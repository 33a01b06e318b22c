"""Tests of bayescal.output: the guard of every output against the inputs and the other outputs, and the atomic writers."""

from __future__ import annotations

import errno
import os
import signal

import pytest

from bayescal.errors import InputError
from bayescal.output import _interrupts_held, forget_written, guard_outputs, write_atomically, write_folder, written_paths


@pytest.fixture
def inputs(tmp_path):
    source = tmp_path / "in.csv"
    source.write_text("a\n1\n")
    os.symlink(source, tmp_path / "link.csv")
    os.link(source, tmp_path / "hard.csv")
    (tmp_path / "folder").mkdir()
    os.symlink(source, tmp_path / "folder" / "a.png")
    return tmp_path, {"the campaign": str(source), "the config": None}


@pytest.mark.parametrize(
    ("files", "folders", "message"),
    [
        ({"-o": "in.csv"}, {}, "-o: in.csv is the campaign"),
        ({"-o": "link.csv"}, {}, "-o: link.csv is the campaign"),
        ({"-o": "hard.csv"}, {}, "-o: hard.csv is the campaign"),
        ({}, {"--figures": ("folder", ("a.png", "b.png"))}, "--figures: folder/a.png is the campaign"),
        ({}, {"--figures": ("in.csv", ("a.png",))}, "--figures: in.csv is the campaign this command reads; expected a folder"),
        ({"-o": "t.md", "--markdown": "t.md"}, {}, "-o: t.md is also the output of --markdown"),
        ({"-o": "folder/b.png"}, {"--figures": ("folder", ("b.png",))}, "is also the output of --figures"),
        ({"-o": "folder"}, {}, "is a directory"),
        ({"-o": "in.csv/x"}, {}, "does not exist"),
        ({}, {"--figures": ("", ("a.png",))}, "--figures: expected the name of a folder"),
    ],
)
def test_the_guard_refuses_outputs_over_inputs_or_each_other_naming_the_option(inputs, monkeypatch, files, folders, message):
    folder, named = inputs
    monkeypatch.chdir(folder)
    with pytest.raises(InputError) as raised:
        guard_outputs(named, files, folders)
    assert str(raised.value).startswith(message) or message in str(raised.value)


def test_the_guard_passes_distinct_new_outputs(inputs, monkeypatch):
    folder, named = inputs
    monkeypatch.chdir(folder)
    guard_outputs(named, {"-o": "out.csv", "--markdown": "out.md", "--none": None}, {"--figures": ("figs", ("a.png",))})


def test_a_failed_write_keeps_the_old_file_and_names_the_output(tmp_path):
    old = tmp_path / "plan.csv"
    old.write_text("old\n")

    def full_disk(path):
        path.write_text("half")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with pytest.raises(InputError, match=rf"^-o: cannot write {old} \(No space left on device\); nothing was replaced$"):
        write_atomically("-o", old, full_disk)
    assert old.read_text() == "old\n" and [p.name for p in tmp_path.iterdir()] == ["plan.csv"]


def test_a_folder_is_written_whole_or_not_at_all(tmp_path):
    forget_written()
    new = tmp_path / "report"
    assert write_folder("-o", new, lambda d: [(d / n).write_text(n) for n in ("a.html", "b.png")]) == [new / "a.html", new / "b.png"]
    assert sorted(p.name for p in new.iterdir()) == ["a.html", "b.png"] and written_paths() == [str(new / "a.html"), str(new / "b.png")]
    (new / "notes.txt").write_text("mine")

    def fails_half_way(staging):
        (staging / "a.html").write_text("new")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with pytest.raises(InputError, match="No space left on device"):
        write_folder("-o", new, fails_half_way)
    assert {p.name: p.read_text() for p in new.iterdir()} == {"a.html": "a.html", "b.png": "b.png", "notes.txt": "mine"}
    write_folder("-o", new, lambda d: [(d / n).write_text("v2") for n in ("a.html", "b.png")])
    assert {p.name: p.read_text() for p in new.iterdir()} == {"a.html": "v2", "b.png": "v2", "notes.txt": "mine"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]


def test_an_interrupt_while_writing_leaves_nothing_behind(tmp_path):
    def half_then_interrupt(path):
        path.write_bytes(b"\x89PNG half")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_folder("--figures", tmp_path / "figures", lambda staging: half_then_interrupt(staging / "a.png"))
    with pytest.raises(KeyboardInterrupt):
        write_atomically("-o", tmp_path / "x.csv", half_then_interrupt)
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_is_held_back_until_the_renames_are_done():
    done = []
    with pytest.raises(KeyboardInterrupt):
        with _interrupts_held():
            os.kill(os.getpid(), signal.SIGINT)
            done.append("renamed")
    assert done == ["renamed"] and signal.getsignal(signal.SIGINT) is signal.default_int_handler
