"""Worker of the slow fuzz test: one JSON request per line in, one JSON outcome per line out.

A request is ``{"argv": [...], "file": "<base64 bytes>" | null}``; with ``file`` the bytes are
written to a scratch file whose path replaces ``"{file}"`` in ``argv``; ``{"checkpoint":
"<base64 bytes>"}`` reads those bytes as a checkpoint file. The answer is
``{"outcome": "ok" | "error" | <traceback>}``. The parent times each answer (a hang) and notices
a worker that dies (a crash).
"""

from __future__ import annotations

import base64
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from fuzz_inputs import checkpoint_outcome, outcome  # noqa: E402


def main() -> int:
    scratch = Path(tempfile.mkdtemp(prefix="mpsfem-fuzz-")) / "scenario.toml"
    for line in sys.stdin:
        req = json.loads(line)
        if req.get("checkpoint") is not None:
            ckpt = scratch.with_name("fuzz.ckpt.h5")
            ckpt.write_bytes(base64.b64decode(req["checkpoint"]))
            print(json.dumps({"outcome": checkpoint_outcome(ckpt)}), flush=True)
            continue
        argv = req["argv"]
        if req.get("file") is not None:
            scratch.write_bytes(base64.b64decode(req["file"]))
            argv = [str(scratch) if a == "{file}" else a for a in argv]
        print(json.dumps({"outcome": outcome(argv)}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
