"""Tests of bayescal.output: the guard of every output against the inputs and the other outputs, and the atomic writers."""

from __future__ import annotations

import errno
import os
import signal

import pytest

from bayescal.errors import InputError
from bayescal.output import (
    _interrupts_held, check_output, forget_reads, forget_written, guard_outputs, read_paths, write_atomically, write_folder, written_paths,
)


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


def test_sigterm_is_held_back_too_then_given_to_the_handler_in_force():
    received = []
    previous = signal.signal(signal.SIGTERM, lambda number, frame: received.append(number))
    try:
        with _interrupts_held():
            os.kill(os.getpid(), signal.SIGTERM)
            held = list(received)
        assert held == [] and received == [signal.SIGTERM]
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_a_file_a_reader_opened_is_refused_by_the_guard_and_by_every_writer(tmp_path):
    from bayescal.tables import read_table

    table = tmp_path / "table.csv"
    table.write_text("a\n1\n")
    os.link(table, tmp_path / "hard.csv")
    forget_reads()
    try:
        # No one names the table to the guard: its reader records it.
        read_table(table, {"a": "number"})
        assert read_paths() == [os.path.realpath(table)]
        refusal = "is a file this command reads: writing there would destroy the input"
        with pytest.raises(InputError, match=f"^-o: {table} {refusal}"):
            check_output("-o", table, {})
        hard_link = f"^-o: {tmp_path / 'hard.csv'} is a file this command reads \\({table}\\): writing there would destroy"
        with pytest.raises(InputError, match=hard_link):
            write_atomically("-o", tmp_path / "hard.csv", lambda path: path.write_text("b\n2\n"))
        with pytest.raises(InputError, match=f"^--figures: {table} {refusal}"):
            write_folder("--figures", tmp_path, lambda staging: (staging / "table.csv").write_text("png"))
        assert sorted(p.name for p in tmp_path.iterdir()) == ["hard.csv", "table.csv"] and table.read_text() == "a\n1\n"
    finally:
        forget_reads()
    check_output("-o", table, {})


READING_CALLS = frozenset({
    "read_text", "read_bytes", "read_csv", "read_json", "read_excel", "open_dataset", "open_datatree", "load_dataset",
    "load_datatree", "buildModelFromUrdf", "buildModelFromXML", "loadtxt", "genfromtxt",
})
"""Calls that read a file given its name, besides ``open`` for reading, ``ElementTree.parse`` and ``np.load``."""


def _reads_a_file(call) -> bool:
    import ast

    function = call.func
    name = function.attr if isinstance(function, ast.Attribute) else getattr(function, "id", None)
    owner = getattr(function.value, "id", None) if isinstance(function, ast.Attribute) else None
    if name == "open" and owner != "os":
        # open(path, mode) or path.open(mode): a mode with w, a, x or + writes.
        modes = call.args[1 if isinstance(function, ast.Name) else 0:][:1] + [k.value for k in call.keywords if k.arg == "mode"]
        return not any(isinstance(mode, ast.Constant) and set(str(mode.value)) & set("wax+") for mode in modes)
    return name in READING_CALLS or (name == "parse" and owner == "ElementTree") or (name == "load" and owner in ("np", "pickle"))


def test_every_function_that_opens_a_file_for_reading_records_it():
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    silent = []
    # the product and the research beside it
    for path in sorted([*(root / "bayescal").rglob("*.py"), *(root / "bayescal_studies").rglob("*.py")]):
        for function in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(function, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            calls = [node for node in ast.walk(function) if isinstance(node, ast.Call)]
            recorded = any(getattr(call.func, "id", None) == "record_read" for call in calls)
            if not recorded and any(_reads_a_file(call) for call in calls):
                silent.append(f"{path.relative_to(root)}:{function.lineno} {function.name}")
    assert not silent, "reads a file without bayescal.output.record_read: " + ", ".join(silent)
