"""A client's proof that a request is its own: a secret the server gave it alone, never sent again.

A client id is no secret: it is in the client's liveliness token and call key, which any session
of the same Zenoh network can read (and, without access control, a session that declares a
queryable on ``<prefix>/call/*`` receives every client's requests). So the id names a client but
does not prove one. What proves it (protocol version 4):

* The first request under an id (the client's ``Hello``, before its liveliness token exists) binds
  the id to a random secret of :data:`SECRET_BYTES` the server makes; the ``Hello`` result carries
  it (``"secret"``, msgpack bin). A reply goes to its querier only, so no other session sees it.
* Every later request carries, as its Zenoh *attachment*, :func:`seal`'s :data:`PROOF_BYTES`:
  a sequence number (8 bytes, big-endian, larger than every earlier one of the client) and the
  16-byte keyed BLAKE2b of that number and the request's payload, keyed by the secret.
  A session that saw such a request can neither make another one (no secret) nor replay it
  (:class:`Window` refuses a number used before).
* A request without a proof under an id the server knows is refused; so is one whose proof does
  not hold. The server forgets the binding with the client's state (``Bye``, its token gone,
  expiry): a client it forgot handshakes again (:data:`UNKNOWN`).
"""

from __future__ import annotations

import hashlib
import hmac
import secrets

SECRET_BYTES = 16
SEQ_BYTES = 8
MAC_BYTES = 16
PROOF_BYTES = SEQ_BYTES + MAC_BYTES
#: Sequence numbers a server accepts below the highest one seen (each once): requests of one
#: client may arrive out of order when sent from several threads.
WINDOW = 64
#: The start of the refusal of a proven request under an id the server does not know (it forgot
#: the client): the client handshakes again (a new ``Hello``, a new secret) and resends.
UNKNOWN = "unknown client"
#: The start of the refusal of a request whose id is bound to a secret it does not prove.
NOT_YOURS = "not this client's"


def new_secret() -> bytes:
    """A fresh secret of :data:`SECRET_BYTES` random bytes (``secrets.token_bytes``)."""
    return secrets.token_bytes(SECRET_BYTES)


def _mac(secret: bytes, seq: bytes, payload: bytes) -> bytes:
    """BLAKE2b keyed with the secret (its MAC mode: RFC 7693), of ``seq`` and then ``payload``,
    a digest of :data:`MAC_BYTES`: about 1.5 us for a request of a call (HMAC-SHA256: 8 us)."""
    mac = hashlib.blake2b(seq, key=secret, digest_size=MAC_BYTES)
    mac.update(payload)
    return mac.digest()


def seal(secret: bytes, seq: int, payload: bytes) -> bytes:
    """The attachment of request number ``seq`` (``0 < seq < 2**64``) carrying ``payload``."""
    head = seq.to_bytes(SEQ_BYTES, "big")
    return head + _mac(secret, head, payload)


def check(secret: bytes, proof: bytes, payload: bytes) -> int | None:
    """The sequence number a proof carries when it holds for ``payload`` under ``secret``, else None."""
    if type(proof) is not bytes or len(proof) != PROOF_BYTES:
        return None
    head = proof[:SEQ_BYTES]
    if not hmac.compare_digest(proof[SEQ_BYTES:], _mac(secret, head, payload)):
        return None
    return int.from_bytes(head, "big")


class Window:
    """The sequence numbers of one client used so far: the highest, and which of the
    :data:`WINDOW` below it were seen. Not thread-safe (the server holds its intake lock)."""

    __slots__ = ("seen", "top")

    def __init__(self) -> None:
        self.top = 0
        self.seen = 0  # bit i: number top - i was used

    def take(self, seq: int) -> bool:
        """Use ``seq``; False when it was used before or is too far below the highest."""
        if seq > self.top:
            shift = seq - self.top
            self.seen = ((self.seen << shift) | 1) & ((1 << WINDOW) - 1) if shift < WINDOW else 1
            self.top = seq
            return True
        back = self.top - seq
        if seq <= 0 or back >= WINDOW or self.seen >> back & 1:
            return False
        self.seen |= 1 << back
        return True
