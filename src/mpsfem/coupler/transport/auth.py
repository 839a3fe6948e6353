"""Authenticated frames for network transports: a per-run secret both participants must hold.

Every message on the wire is sealed as::

    b"MPSFEMA2" | sender's session nonce (16 B) | addressee's session nonce (16 B, zeros before
    the handshake) | sequence number (uint64 LE) | HMAC-SHA256 (32 B) | payload

The link itself is also closed to processes without the token: the listening participant admits
only peers that present a password derived from it (zenoh's user/password authentication), so
another user's process can neither read the interface nor write to it.

The HMAC covers the sender's role, both nonces, the sequence number and the payload, keyed by
SHA-256 of the coupling token. A receiver drops a frame whose HMAC fails (a forged message, or
one of another run with another token), whose sender is not its peer's session (another process
on the same endpoint, or a recorded earlier session), or whose sequence number does not grow (a
replayed frame); a frame of its peer addressed to another session means the peer is coupled to
someone else. The payload itself is not encrypted.

The token, in this order:

1. ``MPSFEM_COUPLING_TOKEN`` (at least 16 characters): export the same value in the shells of a
   two-program launch, e.g. ``export MPSFEM_COUPLING_TOKEN=$(python -c "import secrets;
   print(secrets.token_hex(16))")``. ``mpsfem run S.toml --transport zenoh`` (one command that
   starts the structure itself) sets a fresh random one for its run when none is set;
2. the file named by ``MPSFEM_COUPLING_TOKEN_FILE``;
3. the per-user file ``$XDG_CONFIG_HOME/mpsfem/coupling-token`` (default
   ``~/.config/mpsfem/coupling-token``), created with a random token and mode 0600 when missing,
   so that two programs of the same user find the same token with no setup.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets
import struct
import sys
from pathlib import Path

TOKEN_ENV = "MPSFEM_COUPLING_TOKEN"
TOKEN_FILE_ENV = "MPSFEM_COUPLING_TOKEN_FILE"
MIN_TOKEN_CHARS = 16
FRAME_MAGIC = b"MPSFEMA2"
NONCE_BYTES = 16
MAC_BYTES = 32
HEAD = len(FRAME_MAGIC) + 2 * NONCE_BYTES + 8 + MAC_BYTES
#: the addressee of a frame sent before the peer's session is known
ANYONE = bytes(NONCE_BYTES)


class TokenError(ValueError):
    """No usable coupling token (named variable or file, and what is wrong)."""


def default_token_file() -> Path:
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "mpsfem" / "coupling-token"


def _checked(token: str, where: str) -> str:
    token = token.strip()
    if len(token) < MIN_TOKEN_CHARS:
        raise TokenError(
            f"{where}: the coupling token has {len(token)} characters; at least "
            f'{MIN_TOKEN_CHARS} are needed (e.g. python -c "import secrets; '
            'print(secrets.token_hex(16))")'
        )
    return token


def _read_file(path: Path, where: str) -> str:
    try:
        mode = path.stat().st_mode
        text = path.read_text(encoding="utf-8", errors="strict")
    except (OSError, UnicodeDecodeError) as exc:
        raise TokenError(
            f"{where} = {str(path)!r}: cannot read the coupling token ({exc})"
        ) from None
    if mode & 0o077:
        print(
            f"warning: coupling token file {path} is readable by other users (mode "
            f"{mode & 0o777:o}); chmod 600 it",
            file=sys.stderr,
            flush=True,
        )
    return _checked(text, f"{where} = {str(path)!r}")


def _create_default(path: Path) -> str:
    """The per-user token file, created atomically (two programs starting together agree)."""
    if path.is_file():
        return _read_file(path, "per-user coupling token file")
    try:
        path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "w") as f:
            f.write(secrets.token_hex(32) + "\n")
        try:
            os.link(tmp, path)  # fails if another program created it first: use theirs
        except FileExistsError:
            pass
        finally:
            tmp.unlink(missing_ok=True)
    except OSError as exc:
        raise TokenError(
            f"cannot create the per-user coupling token file {path} ({exc}); set {TOKEN_ENV} "
            f"or {TOKEN_FILE_ENV}"
        ) from None
    return _read_file(path, "per-user coupling token file")


def coupling_token(environ=None) -> str:
    """This run's coupling token (see the module docstring for where it comes from)."""
    environ = os.environ if environ is None else environ
    value = environ.get(TOKEN_ENV)
    if value:
        return _checked(value, TOKEN_ENV)
    file = environ.get(TOKEN_FILE_ENV)
    if file:
        return _read_file(Path(file), TOKEN_FILE_ENV)
    return _create_default(default_token_file())


def new_run_token() -> str:
    """A fresh random token for one run."""
    return secrets.token_hex(32)


class FrameSealer:
    """Seals this side's frames and opens the peer's (see the module docstring)."""

    def __init__(self, token: str, role: str, peer: str) -> None:
        self._key = hashlib.sha256(token.encode("utf-8")).digest()
        self.role, self.peer = role, peer
        self.nonce = secrets.token_bytes(NONCE_BYTES)
        self._seq = 0

    def link_password(self) -> str:
        """The password of the link itself (zenoh user/password authentication), derived from
        the token: a process without it cannot open a link to the listening participant."""
        return hmac.new(self._key, b"mpsfem zenoh link", hashlib.sha256).hexdigest()

    def _mac(self, role: str, head: bytes, payload: bytes | memoryview) -> bytes:
        h = hmac.new(self._key, digestmod=hashlib.sha256)
        h.update(role.encode() + b"\0" + head)
        h.update(payload)
        return h.digest()

    def seal(self, payload: bytes, to: bytes = ANYONE) -> bytes:
        """``payload`` as a frame of this side, addressed to the session ``to``."""
        self._seq += 1
        head = self.nonce + to + struct.pack("<Q", self._seq)
        return b"".join([FRAME_MAGIC, head, self._mac(self.role, head, payload), payload])

    def open(self, frame: bytes) -> tuple[bytes, bytes, int, bytes] | None:
        """(sender nonce, addressee nonce, sequence number, payload) of an authentic frame of
        the peer's role, else None."""
        if len(frame) < HEAD or not frame.startswith(FRAME_MAGIC):
            return None
        i = len(FRAME_MAGIC)
        head = frame[i : i + 2 * NONCE_BYTES + 8]
        mac = frame[i + len(head) : HEAD]
        payload = frame[HEAD:]
        if not hmac.compare_digest(mac, self._mac(self.peer, head, payload)):
            return None
        sender, to = head[:NONCE_BYTES], head[NONCE_BYTES : 2 * NONCE_BYTES]
        return sender, to, struct.unpack("<Q", head[2 * NONCE_BYTES :])[0], payload
