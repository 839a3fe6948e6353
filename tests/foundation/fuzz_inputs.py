"""Inputs for the fuzz tests of ``mpsfem validate``: scenario keys, ``--set`` values, file bytes.

Shared by the in-process CI fuzz test and the subprocess worker of the slow variant
(``fuzz_worker.py``). :func:`outcome` runs the command line in this process and sorts the result
into "ok" (exit 0), "error" (exit 2 with ``error: ...``) or a traceback text (anything else).
"""

from __future__ import annotations

import contextlib
import io
import json
import traceback
import typing
from pathlib import Path

from hypothesis import strategies as st
from pydantic import BaseModel

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "scenarios"
BASES = [
    SCENARIOS / "dam_break_2d.toml",
    SCENARIOS / "structure_cantilever_demo.toml",
    SCENARIOS / "solitary_wave_2d.toml",
    SCENARIOS / "dam_break_elastic_obstacle_2d.toml",
]


def _models(ann) -> list[type[BaseModel]]:
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return [ann]
    return [m for a in typing.get_args(ann) for m in _models(a)]


def _is_list(ann) -> bool:
    if typing.get_origin(ann) is list:
        return True
    return any(_is_list(a) for a in typing.get_args(ann))


def schema_keys() -> list[str]:
    """Every dotted key of the scenario schema (list items as index 0 and 1)."""
    from mpsfem.scenario.schema import Scenario

    keys: list[str] = []

    def walk(model: type[BaseModel], prefix: str, depth: int) -> None:
        for name, f in model.model_fields.items():
            key = f"{prefix}{name}"
            keys.append(key)
            subs = _models(f.annotation)
            if _is_list(f.annotation):
                keys.extend([f"{key}.0", f"{key}.1"])
                if subs:
                    for m in subs if depth < 4 else []:
                        walk(m, f"{key}.0.", depth + 1)
            elif depth < 4:
                for m in subs:
                    walk(m, f"{key}.", depth + 1)

    walk(Scenario, "", 0)
    return sorted(set(keys))


EXTREME_FLOATS = [
    "0.0", "-0.0", "5e-324", "-5e-324", "1e-300", "1e-320", "1e300", "-1e300", "1.7976931348623157e308",
    "inf", "-inf", "nan", "1e15", "1e20", "1e67", "-1", "1e-5", "2.5", "0.5", "1e6", "1e-6",
]  # fmt: skip
EXTREME_INTS = ["0", "-1", "1", "2", "3", "123456789", "9223372036854775807", str(10**30)]
NAMES = ['"."', '".."', '""', '"a/b"', '"x"', '"\\u0000"', '"ü"', '"' + "n" * 300 + '"']


def _float_literal(x: float) -> str:
    return repr(x).replace("inf", "inf").replace("nan", "nan")


scalar_values = st.one_of(
    st.floats(-10.0, 10.0).map(repr),  # often valid: reaches the checks behind the schema
    st.integers(0, 50).map(str),
    st.sampled_from(EXTREME_FLOATS),
    st.sampled_from(EXTREME_INTS),
    st.sampled_from(NAMES),
    st.floats(allow_nan=True, allow_infinity=True).map(_float_literal),
    st.integers(min_value=-(2**70), max_value=2**70).map(str),
    st.text(max_size=20).map(json.dumps),
    st.sampled_from(["true", "false", "pcg_jacobi", "tank", "box", "{}", "[]", "{kind = 1}"]),
)
values = st.recursive(
    scalar_values,
    lambda inner: st.lists(inner, max_size=4).map(lambda xs: "[" + ", ".join(xs) + "]"),
    max_leaves=8,
) | st.integers(1, 700).map(lambda n: "[" * n + "]" * n)


def override_lists(keys: list[str]):
    """Lists of ``KEY=VALUE`` strings: schema keys (some misspelt or made up), odd values."""
    key = st.one_of(
        st.sampled_from(keys),
        st.sampled_from(keys).map(lambda k: k[:-1] or "x"),
        st.text(alphabet="abcxyz._0123456789", min_size=1, max_size=30),
    )
    item = st.one_of(
        st.tuples(key, values).map(lambda kv: f"{kv[0]}={kv[1]}"),
        st.text(max_size=30),  # no '=' at all, or garbage
    )
    return st.lists(item, min_size=1, max_size=3)


def _mutate(base: bytes, cut: int, insert: bytes) -> bytes:
    at = cut % (len(base) + 1)
    return base[:at] + insert + base[at:]


file_bytes = st.one_of(
    st.binary(max_size=200),
    st.tuples(st.sampled_from(BASES), st.integers(0, 10**6), st.binary(max_size=40)).map(
        lambda t: _mutate(t[0].read_bytes(), t[1], t[2])
    ),
    st.tuples(st.sampled_from(BASES), st.integers(0, 10**6)).map(
        lambda t: t[0].read_bytes()[: t[1] % (len(t[0].read_bytes()) + 1)]
    ),
    st.integers(1, 2000).map(lambda n: ("a = " + "[" * n + "]" * n).encode()),
    st.integers(1, 2000).map(lambda n: ("a = " + "{b = " * n + "1" + "}" * n).encode()),
    st.integers(1, 500).map(lambda n: ("[" + ".".join(["t"] * n) + "]\nx = 1\n").encode()),
    st.tuples(st.sampled_from(BASES), st.sampled_from(EXTREME_FLOATS)).map(
        lambda t: t[0].read_bytes().replace(b"spacing = ", f"spacing = {t[1]} #".encode(), 1)
    ),
)


def outcome(argv: list[str]) -> str:
    """'ok', 'error' or a traceback of ``mpsfem <argv>`` run in this process."""
    from mpsfem.cli import main

    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            rc = main(argv)
    except SystemExit as exc:  # argparse: a usage error
        return "error" if exc.code == 2 else f"SystemExit({exc.code})"
    except BaseException:  # noqa: BLE001 - what the fuzz test is looking for
        return traceback.format_exc()
    text = err.getvalue()
    if rc == 0:
        return "ok"
    if rc == 2 and text.startswith("error: ") and "Traceback" not in text:
        return "error"
    return f"exit {rc}: {text[-2000:]}"


def checkpoint_outcome(path: Path) -> str:
    """'ok', 'error' (CheckpointError) or a traceback of reading the checkpoint at ``path``."""
    from mpsfem.results.checkpoint import CheckpointError, read_checkpoint

    try:
        read_checkpoint(path)
    except CheckpointError:
        return "error"
    except BaseException:  # noqa: BLE001 - what the fuzz test is looking for
        return traceback.format_exc()
    return "ok"


def checkpoint_bytes(good: bytes):
    """A good checkpoint's bytes with a few bytes overwritten, or cut short."""
    flip = st.tuples(st.integers(0, len(good) - 1), st.binary(min_size=1, max_size=8))

    def overwrite(edits: list[tuple[int, bytes]]) -> bytes:
        out = bytearray(good)
        for at, data in edits:
            out[at : at + len(data)] = data
        return bytes(out[: len(good)])

    return st.one_of(
        st.lists(flip, min_size=1, max_size=6).map(overwrite),
        st.integers(0, len(good)).map(lambda n: good[:n]),
    )


def validate_argv(path: Path, overrides: list[str]) -> list[str]:
    argv = ["validate", str(path)]
    for item in overrides:
        argv += ["--set", item]
    return argv
