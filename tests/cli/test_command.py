"""Tests of bayescal.cli._command: option types, the output guard and atomic writing."""

from __future__ import annotations

import argparse
import os
import stat

import pytest

from bayescal.cli._command import check_output, whole_number, write_atomically
from bayescal.errors import InputError


@pytest.mark.parametrize("text", ["-1", "1_0", "1.0", "abc", "", " ", "٣", "1e3"])
def test_whole_number_rejects_anything_but_digits_at_or_above_the_minimum(text):
    with pytest.raises(argparse.ArgumentTypeError, match="expected a whole number >= 0"):
        whole_number(0)(text)


def test_whole_number_reads_signs_and_digits():
    assert whole_number(0)("+7") == 7 and whole_number(-5)("-5") == -5 and whole_number(0)("0") == 0


@pytest.fixture
def files(tmp_path):
    source = tmp_path / "in.csv"
    source.write_text("a\n1\n")
    os.symlink(source, tmp_path / "link.csv")
    os.link(source, tmp_path / "hard.csv")
    (tmp_path / "sub").mkdir()
    return tmp_path, source


@pytest.mark.parametrize("name", ["in.csv", "link.csv", "hard.csv", "sub/../in.csv"])
def test_an_output_that_is_an_input_is_refused_under_any_name(files, name, monkeypatch):
    folder, source = files
    monkeypatch.chdir(folder)
    with pytest.raises(InputError) as raised:
        check_output("-o", name, {"the plan": str(source), "the config": None})
    assert str(raised.value).startswith(f"-o: {name} is the plan") and "would destroy the input" in str(raised.value)


@pytest.mark.parametrize(
    ("name", "message"),
    [("sub", "is a directory"), ("absent/x.csv", "the output folder"), ("new.csv", None)],
)
def test_output_paths_that_cannot_be_written_are_refused_before_any_work(files, name, message):
    folder, source = files
    if message is None:
        check_output("--posterior", folder / name, {"the campaign": source})
        return
    with pytest.raises(InputError, match=message):
        check_output("--posterior", folder / name, {"the campaign": source})


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write a read-only file")
def test_a_read_only_output_is_refused(tmp_path):
    path = tmp_path / "out.csv"
    path.write_text("old")
    path.chmod(stat.S_IRUSR)
    with pytest.raises(InputError, match="is read-only"):
        check_output("-o", path, {})


def test_write_replaces_the_file_whole_and_keeps_its_mode(tmp_path):
    path = tmp_path / "out.csv"
    path.write_text("old")
    path.chmod(0o640)
    write_atomically("-o", path, lambda temporary: temporary.write_text("new"))
    assert path.read_text() == "new" and stat.S_IMODE(path.stat().st_mode) == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]


def test_an_interrupted_write_leaves_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "out.csv"
    path.write_text("old")

    def interrupted(temporary):
        temporary.write_text("half")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_atomically("-o", path, interrupted)
    assert path.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]


def test_a_failed_write_is_an_input_error_naming_the_option(tmp_path):
    def full(temporary):
        raise OSError(28, "No space left on device")

    with pytest.raises(InputError, match=r"^--posterior: cannot write .*out.nc \(No space left on device\)"):
        write_atomically("--posterior", tmp_path / "out.nc", full)
    assert list(tmp_path.iterdir()) == []


def test_writing_through_a_symlink_replaces_its_target(tmp_path):
    target = tmp_path / "real.csv"
    target.write_text("old")
    os.symlink(target, tmp_path / "link.csv")
    write_atomically("-o", tmp_path / "link.csv", lambda temporary: temporary.write_text("new"))
    assert (tmp_path / "link.csv").is_symlink() and target.read_text() == "new"
