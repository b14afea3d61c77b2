"""``dsmpepc list | head -1``: a reader that leaves early gets no traceback (issue 31)."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_a_closed_pipe_ends_the_command_quietly():
    read, write = os.pipe()
    os.close(read)                          # the reader is gone before the command writes
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-m", "dsmpepc_nlp.cli", "list"], stdout=write,
                          stderr=subprocess.PIPE, text=True, cwd=ROOT, env=env, timeout=120)
    os.close(write)
    assert done.stderr == "" and done.returncode == 141


def test_an_open_pipe_still_gets_everything():
    done = subprocess.run([sys.executable, "-m", "dsmpepc_nlp.cli", "list"], capture_output=True,
                          text=True, cwd=ROOT, timeout=120)
    assert done.returncode == 0 and "t-corridor" in done.stdout and done.stderr == ""
