# Copyright 2026 formation_control developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Signed control topics in a TLS fleet: who may publish what, and who is revoked (pure).

A TLS fleet (:mod:`formation_control.ops.security`) admits its members, but every member is
trusted with every topic. In a fleet written with signing (``fleet_certs.pem`` in each
member's directory), each control-relevant message also goes out as a **signed envelope** on
``TOPIC/signed`` (:data:`SUFFIX`), a std_msgs/UInt8MultiArray whose ``data`` is::

    b'FCS1' | signer length (uint8) | signer | topic length (uint16 LE) | topic
            | sequence (uint64 LE) | payload length (uint32 LE) | payload | signature (64)

``topic`` is the resolved name of the plain topic, ``payload`` the plain message's CDR bytes
as sent on it, ``signature`` ECDSA P-256 / SHA-256 over every byte before it (r || s, 32 bytes
each, big endian), by the signer's member key. The receivers of the control loop (vehicles,
plant) take only the envelopes, and only from :func:`signer_for` of the topic: ``vehicle_k``
for ``vehicle_k/formation_state`` and ``vehicle_k/cmd``, ``plant`` for ``vehicle_k/odom`` and
``/clock``. A signer's sequence is its wall clock (ns) when it seals, kept strictly increasing,
so it grows across restarts; a receiver keeps the last of each (signer, topic) and drops any
not above it, or older than :data:`WINDOW` on its own wall clock (:class:`ReplayWindow`). A
dropped envelope is a :class:`~formation_control.protocol.intake.Rejection` of one of
:data:`KINDS` (or ``malformed``); the payload of an accepted one goes through the topic's
intake as the plain bytes would.

Revocation is an X.509 CRL signed by the fleet's CA (``crl.pem``, :func:`revoke`): a member
whose certificate's serial is on it is refused at start-up (:func:`check_member`) and its
envelopes are dropped (``revoked``) once a receiver has reloaded the list (:class:`Revocations`).
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
import datetime
import os
from pathlib import Path
import re
import struct
import time
from typing import Any

from formation_control.ops.security import CERTS, CRL, PROFILE, SecurityError
from formation_control.protocol.intake import MALFORMED, Rejection

MAGIC = b'FCS1'
SUFFIX = '/signed'
SIGNATURE = 64
UNSIGNED, BAD_SIGNATURE, WRONG_SIGNER = 'unsigned', 'bad_signature', 'wrong_signer'
WRONG_TOPIC, UNKNOWN_SIGNER, REPLAY, REVOKED = ('wrong_topic', 'unknown_signer', 'replay',
                                                'revoked')
WINDOW = 60 * 10**9
"""How old (ns, on the receiver's wall clock) a sequence may be: the hosts' clocks must agree
within it; a receiver that starts afresh takes no envelope sealed before it."""
KINDS = (UNSIGNED, BAD_SIGNATURE, WRONG_SIGNER, WRONG_TOPIC, UNKNOWN_SIGNER, REPLAY, REVOKED)
"""The reasons an envelope is dropped, besides ``malformed`` (envelope bytes that do not parse)."""
ARRAY_HEADER = struct.Struct('<4sIII')
"""A std_msgs/UInt8MultiArray with no layout dimensions: encapsulation, dim size (0),
data_offset (0), data size; the data bytes follow."""
ENCAPSULATION = b'\x00\x01\x00\x00'
_VEHICLE_TOPIC = re.compile(r'(?:^|/)vehicle_([1-9]\d*)/(formation_state|cmd|cmd_vel|odom)$')
_CLOCK_TOPIC = re.compile(r'(?:^|/)clock$')


def signer_for(topic: str) -> str | None:
    """
    Return the member that alone may sign the messages of (resolved) ``topic``, or None.

    ``vehicle_k`` its ``formation_state``, ``cmd`` and (an aircraft) ``cmd_vel``; ``plant`` every
    ``odom`` and the fleet's ``clock`` (``/clock``, or a namespace's).
    """
    if _CLOCK_TOPIC.search(topic):
        return 'plant'
    match = _VEHICLE_TOPIC.search(topic)
    if match is None:
        return None
    return 'plant' if match.group(2) == 'odom' else f'vehicle_{match.group(1)}'


@dataclass(frozen=True)
class Envelope:
    """A parsed envelope: ``signed`` is every byte its ``signature`` covers."""

    signer: str
    topic: str
    sequence: int
    payload: bytes
    signed: bytes
    signature: bytes


def signed_bytes(signer: str, topic: str, sequence: int, payload: bytes) -> bytes:
    """Return the bytes a signer signs: the envelope up to its signature."""
    name, where = signer.encode(), topic.encode()
    return b''.join((MAGIC, struct.pack('<B', len(name)), name, struct.pack('<H', len(where)),
                     where, struct.pack('<QI', sequence, len(payload)), payload))


def array_message(body: bytes) -> bytes:
    """Return the CDR bytes of a UInt8MultiArray of ``body``."""
    return ARRAY_HEADER.pack(ENCAPSULATION, 0, 0, len(body)) + body


def array_body(data: bytes) -> bytes | None:
    """Return the ``data`` of a UInt8MultiArray's CDR bytes without layout, else None."""
    if len(data) < ARRAY_HEADER.size:
        return None
    head, dims, _, size = ARRAY_HEADER.unpack_from(data)
    end = ARRAY_HEADER.size + size
    if head != ENCAPSULATION or dims != 0 or not end <= len(data) < end + 4:
        return None
    return data[ARRAY_HEADER.size:end]


def parse(data: bytes, topic: str) -> Envelope | Rejection:
    """Return the envelope of the CDR bytes received on ``topic``'s envelopes, or why not."""
    body = array_body(data)
    if body is None or not body.startswith(MAGIC):
        return Rejection(UNSIGNED, f'a message on {topic}{SUFFIX} that is no signed envelope')
    try:
        at = len(MAGIC)
        signer = body[at + 1:at + 1 + body[at]].decode()
        at += 1 + body[at]
        (size,) = struct.unpack_from('<H', body, at)
        where = body[at + 2:at + 2 + size].decode()
        at += 2 + size
        sequence, size = struct.unpack_from('<QI', body, at)
        at += 12
    except (IndexError, struct.error, UnicodeDecodeError):
        return Rejection(MALFORMED, f'a truncated signed envelope on {topic}{SUFFIX}')
    if len(body) != at + size + SIGNATURE:
        return Rejection(MALFORMED, f'a signed envelope on {topic}{SUFFIX} of {len(body)} bytes '
                                    f'(its fields give {at + size + SIGNATURE})')
    return Envelope(signer, where, sequence, body[at:at + size], body[:at + size],
                    body[at + size:])


class ReplayWindow:
    """
    The last sequence accepted of each (signer, topic): an envelope must exceed it.

    It must also be within ``window`` ns before ``clock()`` (the wall clock, ns).
    """

    def __init__(self, window: int = WINDOW, clock: Callable[[], int] = time.time_ns) -> None:
        self.last: dict[tuple[str, str], int] = {}
        self.window, self.clock = window, clock

    def fresh(self, signer: str, topic: str, sequence: int) -> bool:
        """Return whether ``sequence`` is above the last of (signer, topic), and recent."""
        return (sequence > self.last.get((signer, topic), -1)
                and sequence > self.clock() - self.window)

    def accept(self, signer: str, topic: str, sequence: int) -> None:
        """Record ``sequence`` as the last accepted of (signer, topic)."""
        self.last[signer, topic] = sequence


class Signer:
    """
    Seals the messages member ``name`` publishes: ``sign(bytes) -> 64-byte signature``.

    The sequence of an envelope is ``clock()`` (the wall clock, ns), or one above the last if
    that is not more.
    """

    def __init__(self, name: str, sign: Callable[[bytes], bytes],
                 clock: Callable[[], int] = time.time_ns) -> None:
        self.name, self.sign, self.clock = name, sign, clock
        self.sequence = 0

    def seal(self, topic: str, payload: bytes) -> bytes:
        """Return the CDR bytes of the envelope of ``payload`` (sent on ``topic``)."""
        self.sequence = max(self.sequence + 1, self.clock())
        signed = signed_bytes(self.name, topic, self.sequence, payload)
        return array_message(signed + self.sign(signed))


class Verifier:
    """
    Opens envelopes: checks topic, signer, revocation, signature and sequence, in that order.

    Parameters
    ----------
    verify : mapping
        {member name: callable(signature, signed bytes) -> bool}, from the roster's
        certificates.
    revoked : callable
        () -> the names of the revoked members (read at each envelope: reloadable).
    window : ReplayWindow, optional
        The sequences accepted so far (default: a new one).

    """

    def __init__(self, verify: Mapping[str, Callable[[bytes, bytes], bool]],
                 revoked: Callable[[], frozenset[str]],
                 window: ReplayWindow | None = None) -> None:
        self.verify, self.revoked = verify, revoked
        self.window = ReplayWindow() if window is None else window

    def unseal(self, topic: str, data: bytes) -> bytes | Rejection:
        """Return the payload of envelope bytes received for ``topic``, or their rejection."""
        got = parse(data, topic)
        if isinstance(got, Rejection):
            return got
        what = f'a message on {topic} signed by {got.signer!r}'
        expected = signer_for(topic)
        if got.topic != topic:
            return Rejection(WRONG_TOPIC, f'{what} for {got.topic!r}')
        if got.signer != expected:
            return Rejection(WRONG_SIGNER, f'{what} (only {expected!r} may publish it)')
        if got.signer in self.revoked():
            return Rejection(REVOKED, f'{what}, a revoked member')
        check = self.verify.get(got.signer)
        if check is None:
            return Rejection(UNKNOWN_SIGNER, f'{what}, whose certificate is not in the roster')
        if not check(got.signature, got.signed):
            return Rejection(BAD_SIGNATURE, f'{what} whose signature does not verify')
        if not self.window.fresh(got.signer, topic, got.sequence):
            return Rejection(REPLAY, f'{what} of sequence {got.sequence}: not after the last '
                                     f'accepted, or over {self.window.window * 1e-9:g} s old')
        self.window.accept(got.signer, topic, got.sequence)
        return got.payload


def member_home(env: Mapping[str, str]) -> Path | None:
    """Return the member directory of a process of a signing fleet, else None."""
    profile = env.get('FASTRTPS_DEFAULT_PROFILES_FILE')
    if not profile or Path(profile).name != PROFILE:
        return None
    home = Path(profile).parent
    return home if (home / CERTS).is_file() else None


def _load_certs(home: Path) -> dict[str, Any]:
    """Return {member: certificate} of ``fleet_certs.pem``, each checked against ``ca.pem``."""
    from cryptography import x509
    from cryptography.exceptions import InvalidSignature
    ca = x509.load_pem_x509_certificate((home / 'ca.pem').read_bytes())
    out = {}
    for cert in x509.load_pem_x509_certificates((home / CERTS).read_bytes()):
        name = common_name(cert)
        try:
            cert.verify_directly_issued_by(ca)
        except (InvalidSignature, TypeError, ValueError) as err:
            raise SecurityError(f'{home / CERTS}: the certificate of {name} is not signed by '
                                f'the fleet CA ({home / "ca.pem"}): {err}') from None
        out[name] = cert
    return out


def common_name(cert: Any) -> str:
    """Return the common name (CN) of a certificate: a member's name."""
    from cryptography.x509.oid import NameOID
    value = cert.subject.get_attributes_for_oid(NameOID.COMMON_NAME)[0].value
    return value.decode() if isinstance(value, bytes) else str(value)


def _verifier(public_key: Any) -> Callable[[bytes, bytes], bool]:
    from cryptography.exceptions import InvalidSignature
    from cryptography.hazmat.primitives import hashes
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.hazmat.primitives.asymmetric.utils import encode_dss_signature
    algorithm = ec.ECDSA(hashes.SHA256())

    def verify(signature: bytes, signed: bytes) -> bool:
        der = encode_dss_signature(int.from_bytes(signature[:32], 'big'),
                                   int.from_bytes(signature[32:], 'big'))
        try:
            public_key.verify(der, signed, algorithm)
        except InvalidSignature:
            return False
        return True
    return verify


def sign_with(private_key: Any) -> Callable[[bytes], bytes]:
    """Return the raw (r || s) ECDSA P-256 / SHA-256 signer of ``private_key``."""
    from cryptography.hazmat.primitives import hashes
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.hazmat.primitives.asymmetric.utils import decode_dss_signature
    algorithm = ec.ECDSA(hashes.SHA256())

    def sign(signed: bytes) -> bytes:
        r, s = decode_dss_signature(private_key.sign(signed, algorithm))
        return r.to_bytes(32, 'big') + s.to_bytes(32, 'big')
    return sign


def load_key(path: Path) -> Any:
    """Return the private key of the PEM file ``path``."""
    from cryptography.hazmat.primitives import serialization
    return serialization.load_pem_private_key(Path(path).read_bytes(), None)


class Revocations:
    """
    The revoked members of ``home/crl.pem``, reloaded when the file changes.

    The CRL must be signed by the fleet's CA (``home/ca.pem``); a member is revoked when the
    serial of its roster certificate is listed. No file: no one is revoked.
    """

    def __init__(self, home: Path, certs: Mapping[str, Any]) -> None:
        self.path, self.certs = Path(home) / CRL, certs
        self.ca = Path(home) / 'ca.pem'
        self.stamp: tuple[int, int] | None = None
        self.names: frozenset[str] = frozenset()
        self.refresh()

    def __call__(self) -> frozenset[str]:
        """Return the names of the revoked members."""
        return self.names

    def refresh(self) -> bool:
        """Reload the list if its file changed; return whether the revoked members changed."""
        try:
            st = os.stat(self.path)
            stamp: tuple[int, int] | None = (st.st_mtime_ns, st.st_size)
        except FileNotFoundError:
            stamp = None
        if stamp == self.stamp:
            return False
        names = self._read() if stamp is not None else frozenset()
        self.stamp = stamp
        changed, self.names = names != self.names, names
        return changed

    def _read(self) -> frozenset[str]:
        from cryptography import x509
        ca = x509.load_pem_x509_certificate(self.ca.read_bytes())
        try:
            crl = x509.load_pem_x509_crl(self.path.read_bytes())
        except ValueError as err:
            raise SecurityError(f'{self.path}: not a revocation list ({err})') from None
        if not crl.is_signature_valid(ca.public_key()):
            raise SecurityError(f'{self.path}: the revocation list is not signed by the fleet CA '
                                f'({self.ca})')
        serials = {entry.serial_number for entry in crl}
        return frozenset(name for name, cert in self.certs.items()
                         if cert.serial_number in serials)


@dataclass
class Member:
    """This process's side of a signing fleet: its name, its signer, its verifier."""

    name: str
    home: Path
    signer: Signer
    verifier: Verifier
    revocations: Revocations


def load_member(home: Path) -> Member:
    """Return the signing side of the member whose directory is ``home``."""
    from cryptography import x509
    certs = _load_certs(home)
    name = common_name(x509.load_pem_x509_certificate((home / 'cert.pem').read_bytes()))
    revocations = Revocations(home, certs)
    verifier = Verifier({m: _verifier(c.public_key()) for m, c in certs.items()}, revocations)
    return Member(name, home, Signer(name, sign_with(load_key(home / 'key.pem'))), verifier,
                  revocations)


def check_member(env: Mapping[str, str]) -> str | None:
    """
    Return why this process may not start as its member of a signing fleet, or None.

    A revoked member, a revocation list not signed by the CA, or a roster certificate the CA
    did not sign, is refused.
    """
    home = member_home(env)
    if home is None:
        return None
    try:
        member = load_member(home)
    except (SecurityError, OSError, ValueError) as err:
        return f'{home.name}: {err}'
    if member.name in member.revocations():
        return (f"member {member.name} is revoked by the fleet's revocation list "
                f'{member.revocations.path} (formation-control secure revoke): it may not join')
    return None


def revoke(directory: Path, name: str) -> list[str]:
    """
    Add member ``name`` of the fleet in ``directory`` to its CRL, signed by the fleet's CA.

    Writes ``directory/ca/crl.pem`` (the revoked so far kept) and a copy into every member's
    directory (copy those out to the hosts); returns the names on the list.
    """
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from formation_control.ops.security import load_ca
    directory = Path(directory)
    cert_path = directory / name / 'cert.pem'
    if not cert_path.is_file():
        raise SecurityError(f'{cert_path} does not exist: {name} is not a member of the fleet '
                            f'in {directory}')
    ca_cert, ca_key = load_ca(directory / 'ca')
    target = x509.load_pem_x509_certificate(cert_path.read_bytes())
    entries, number = _existing(directory / 'ca' / CRL, ca_cert)
    now = datetime.datetime.now(datetime.timezone.utc)
    if target.serial_number not in {e.serial_number for e in entries}:
        entries.append(x509.RevokedCertificateBuilder().serial_number(target.serial_number)
                       .revocation_date(now).build())
    builder = (x509.CertificateRevocationListBuilder().issuer_name(ca_cert.subject)
               .last_update(now).next_update(now + datetime.timedelta(days=365))
               .add_extension(x509.CRLNumber(number + 1), critical=False))
    for entry in entries:
        builder = builder.add_revoked_certificate(entry)
    data = builder.sign(ca_key, hashes.SHA256()).public_bytes(serialization.Encoding.PEM)
    _replace(directory / 'ca' / CRL, data)
    for home in sorted(p.parent for p in directory.glob(f'*/{PROFILE}')):
        _replace(home / CRL, data)
    serials = {e.serial_number for e in entries}
    return sorted(p.parent.name for p in directory.glob('*/cert.pem')
                  if p.parent.name != 'ca' and x509.load_pem_x509_certificate(
                      p.read_bytes()).serial_number in serials)


def _existing(path: Path, ca_cert: Any) -> tuple[list[Any], int]:
    """Return the entries and number of the CRL at ``path`` (none: ([], 0))."""
    from cryptography import x509
    if not path.is_file():
        return [], 0
    crl = x509.load_pem_x509_crl(path.read_bytes())
    if not crl.is_signature_valid(ca_cert.public_key()):
        raise SecurityError(f'{path}: the revocation list is not signed by the fleet CA')
    number = crl.extensions.get_extension_for_class(x509.CRLNumber).value.crl_number
    return list(crl), number


def _replace(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically: a reloading receiver never reads half a list."""
    part = path.with_name(path.name + '.part')
    part.write_bytes(data)
    os.replace(part, path)
