"""Signals that end a run: Ctrl-C (SIGINT), SIGTERM (``timeout``, a scheduler) and SIGHUP (a closed terminal).

Each ends any command with one line, exit status 128 + the signal, no output and no temporary file left
beside it: in this process while an output is half written, and on a real ``bayescal compensate`` of a
long program, signalled from outside while it works.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from bayescal.cli import main
from bayescal_studies.studies.compensation import random_program

DATA = Path(__file__).resolve().parents[2] / "data"
PROC = Path("/proc")


@pytest.mark.parametrize(("number", "status"), [(signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_a_signal_while_the_output_is_written_leaves_no_temporary_file(capsys, monkeypatch, tmp_path, number, status):
    from bayescal.design.optimise import PlanDesign

    def half_then_signalled(self, path, comments=()):
        Path(path).write_text("q1_deg,q2_deg\n0,")
        os.kill(os.getpid(), number)

    monkeypatch.setattr("bayescal.design.optimise.PlanDesigner.optimise", lambda self, *a, **k: PlanDesign.__new__(PlanDesign))
    monkeypatch.setattr(PlanDesign, "save", half_then_signalled)
    handlers = {n: signal.getsignal(n) for n in (signal.SIGTERM, signal.SIGHUP)}
    code = main(["plan", "--config", str(DATA / "kr270.toml"), "-o", str(tmp_path / "plan.csv")])
    assert code == status and capsys.readouterr().err.strip().splitlines() == ["bayescal plan: interrupted; nothing written"]
    assert list(tmp_path.iterdir()) == []
    assert {n: signal.getsignal(n) for n in handlers} == handlers


def _catches(pid: int, number: int) -> bool:
    """Whether process ``pid`` has installed a handler for signal ``number`` (``SigCgt`` of ``/proc/PID/status``)."""
    status = (PROC / str(pid) / "status").read_text()
    caught = int(next(line.split()[1] for line in status.splitlines() if line.startswith("SigCgt:")), 16)
    return bool(caught >> (number - 1) & 1)


def _bytes_read(pid: int) -> int:
    """Bytes process ``pid`` has read so far (``rchar`` of ``/proc/PID/io``)."""
    io = (PROC / str(pid) / "io").read_text()
    return int(next(line.split()[1] for line in io.splitlines() if line.startswith("rchar:")))


def _wait_for(condition, process: subprocess.Popen, timeout: float, every: float = 0.05) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline, "the run did not get there in time"
        time.sleep(every)


def _compensate_then_signal(tmp_path: Path, cell, calibration: Path, poses: int, number: int, when: str) -> tuple[int, list[str]]:
    """Run ``bayescal compensate`` on a program of ``poses`` poses and send it ``number``.

    ``when``: ``"read"``, once it has read the program (it then works for minutes); ``"writing"``, once
    its temporary output exists.  Returns the exit status and the lines on stderr.
    """
    program = tmp_path / "program.csv"
    # 1000 random poses of the library's generator, repeated: the run's work grows with the rows, not their variety.
    header, rows = random_program(cell, 1000, np.random.default_rng(0)).table.to_csv(index=False).split("\n", 1)
    program.write_text(header + "\n" + rows * (poses // 1000))
    argv = [sys.executable, "-m", "bayescal", "compensate", str(program), "--calibration", str(calibration),
            "--config", str(DATA / "kr270.toml"), "-o", str(tmp_path / "compensated.csv")]
    # Ctrl-C reaches a program only when its parent does not ignore SIGINT (a background job of a script does).
    process = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        _wait_for(lambda: _catches(process.pid, signal.SIGTERM), process, timeout=120)
        if when == "read":
            start = _bytes_read(process.pid)
            _wait_for(lambda: _bytes_read(process.pid) - start >= program.stat().st_size, process, timeout=300)
        else:
            # The write of 20,000 rows lasts about 0.5 s: polled every 2 ms.
            _wait_for(lambda: any(tmp_path.glob(".compensated.csv.*.tmp.csv")), process, timeout=600, every=0.002)
        process.send_signal(number)
        _, err = process.communicate(timeout=120)
        return process.returncode, err.strip().splitlines()
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
        program.unlink()  # 136 MB for 10^6 poses, which pytest would otherwise keep with its last runs' folders


needs_proc = pytest.mark.skipif(not (PROC / "self" / "io").is_file(), reason="needs Linux's /proc to see when the run has read its program")


@needs_proc
@pytest.mark.parametrize(("number", "status"), [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_compensate_of_a_million_poses_ended_by_a_signal_leaves_nothing(tmp_path, cell, short_calibration, number, status):
    code, lines = _compensate_then_signal(tmp_path, cell, Path(short_calibration["calibration"]), 1_000_000, number, "read")
    assert code == status and lines == ["bayescal compensate: interrupted; nothing written"]
    assert list(tmp_path.iterdir()) == []


@needs_proc
@pytest.mark.slow  # 8-13 s each (measured): the 20,000 poses are compensated before the write begins
@pytest.mark.parametrize(("number", "status"), [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_compensate_signalled_while_writing_removes_its_temporary_file(tmp_path, cell, short_calibration, number, status):
    code, lines = _compensate_then_signal(tmp_path, cell, Path(short_calibration["calibration"]), 20_000, number, "writing")
    assert code == status and lines == ["bayescal compensate: interrupted; nothing written"]
    assert list(tmp_path.iterdir()) == []
