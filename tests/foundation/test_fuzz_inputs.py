"""Fuzzing ``mpsfem validate`` (issue 22): no input, file or ``--set`` ends in a traceback or a
hang, only in ``error: ...`` (exit 2) or a valid scenario (exit 0).

* the CI set: in process, fixed seed, a few seconds; also damaged bytes of a real checkpoint
  (``read_checkpoint`` raises CheckpointError or reads it);
* the slow set (``-m slow``): at least 2,000 inputs through a worker subprocess that is timed per
  input (a hang) and watched for dying (a crash); it prints tries, clear errors, tracebacks and
  hangs.
"""

from __future__ import annotations

import base64
import json
import os
import select
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

import pytest
from fuzz_inputs import (
    BASES,
    checkpoint_bytes,
    checkpoint_outcome,
    file_bytes,
    outcome,
    override_lists,
    schema_keys,
    validate_argv,
)
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

KEYS = schema_keys()
FUZZ_SEED = 22
CI = settings(
    max_examples=40,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


@pytest.fixture(scope="module")
def good_checkpoint(tmp_path_factory) -> bytes:
    """The bytes of a real checkpoint (three dam-break steps, with an AMG hierarchy)."""
    from mpsfem.cli import main

    out = tmp_path_factory.mktemp("fuzz") / "d.h5"
    dam = str(BASES[0])
    assert main(["run", dam, "--end-time", "0.003", "--out", str(out), "--no-progress"]) == 0
    return out.with_name("d.ckpt.h5").read_bytes()


def test_schema_keys_cover_the_schema():
    assert "fluid.spacing" in KEYS and "fluid.walls.0.upper" in KEYS
    assert "structure.time.dt" in KEYS and "probes.0.name" in KEYS


@seed(FUZZ_SEED)
@CI
@given(base=st.sampled_from(BASES), overrides=override_lists(KEYS))
def test_set_values_give_a_clear_error_or_a_scenario(base, overrides):
    result = outcome(validate_argv(base, overrides))
    assert result in ("ok", "error"), result


@seed(FUZZ_SEED)
@CI
@given(data=file_bytes)
def test_file_bytes_give_a_clear_error_or_a_scenario(data):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "fuzz.toml"
        path.write_bytes(data)
        result = outcome(["validate", str(path)])
    assert result in ("ok", "error"), result


@CI
@given(data=st.data())
def test_damaged_checkpoint_bytes_give_a_checkpoint_error_or_a_checkpoint(good_checkpoint, data):
    damaged = data.draw(checkpoint_bytes(good_checkpoint))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "fuzz.ckpt.h5"
        path.write_bytes(damaged)
        result = checkpoint_outcome(path)
    assert result in ("ok", "error"), result


# ------------------------------------------------------------------ the slow subprocess variant
ROOT = Path(__file__).resolve().parents[2]
WORKER = Path(__file__).with_name("fuzz_worker.py")
PER_INPUT_TIMEOUT_S = 30.0
SLOW_EXAMPLES = 2000


class Worker:
    """A fuzz worker process; a hang (no answer in time) or a crash restarts it."""

    def __init__(self) -> None:
        self.env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "NUMBA_NUM_THREADS": "1"}
        self.proc: subprocess.Popen | None = None

    def _start(self) -> subprocess.Popen:
        return subprocess.Popen(
            [sys.executable, str(WORKER)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
            env=self.env,
        )

    def ask(self, argv: list[str] | None, data: bytes | None) -> str:
        """The outcome of ``argv`` (with ``data`` as the scenario file), or of reading ``data``
        as a checkpoint where ``argv`` is None."""
        if self.proc is None or self.proc.poll() is not None:
            self.proc = self._start()
        b64 = None if data is None else base64.b64encode(data).decode()
        req = {"argv": argv, "file": b64} if argv is not None else {"checkpoint": b64}
        self.proc.stdin.write(json.dumps(req) + "\n")
        self.proc.stdin.flush()
        ready, _, _ = select.select([self.proc.stdout], [], [], PER_INPUT_TIMEOUT_S)
        if not ready:
            self.stop()
            return "hang"
        line = self.proc.stdout.readline()
        if not line:
            code = self.proc.wait()
            self.proc = None
            return f"crash (exit {code})"
        return json.loads(line)["outcome"]

    def stop(self) -> None:
        if self.proc is not None:
            self.proc.kill()
            self.proc.wait()
            self.proc = None


@pytest.mark.slow
def test_fuzz_in_a_subprocess_no_traceback_no_hang(good_checkpoint):
    worker = Worker()
    tally: Counter[str] = Counter()
    bad: list[tuple[list[str], str]] = []

    inputs = st.one_of(
        st.tuples(st.sampled_from(BASES), override_lists(KEYS)).map(
            lambda t: (validate_argv(t[0], t[1]), None)
        ),
        file_bytes.map(lambda b: (["validate", "{file}"], b)),
        checkpoint_bytes(good_checkpoint).map(lambda b: (None, b)),
    )

    @seed(FUZZ_SEED)
    @settings(
        max_examples=SLOW_EXAMPLES,
        deadline=None,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(case=inputs)
    def one(case):
        argv, data = case
        result = worker.ask(argv, data)
        kind = result if result in ("ok", "error", "hang") else "traceback"
        tally[kind] += 1
        tally[f"{kind} ({'checkpoint' if argv is None else 'validate'})"] += 1
        if kind in ("traceback", "hang"):
            bad.append((argv or "checkpoint", result))

    try:
        one()
    finally:
        worker.stop()
    tries = sum(n for k, n in tally.items() if "(" not in k)
    print(
        f"\nfuzz: {tries} tries, {tally['ok']} valid, {tally['error']} clear errors, "
        f"{tally['traceback']} tracebacks, {tally['hang']} hangs; by input: "
        + ", ".join(f"{k}: {n}" for k, n in sorted(tally.items()) if "(" in k)
    )
    assert tries >= SLOW_EXAMPLES
    assert not bad, bad[:3]
