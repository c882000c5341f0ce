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
``formation-control secure``: a fleet only its members can join, over Fast DDS TLS (pure).

Every member process (the plant, the monitor, the swarm's own node, an operator's tools, each
vehicle) gets a key and a certificate signed by the fleet's own CA, a Fast DDS profile with
TCPv4 + TLS as its only transport (a listening port of its own, every other member as an
initial peer) and an OpenSSL configuration that makes its listener demand and verify a peer
certificate. Fast DDS 2.14 applies the profile's ``verify_mode`` only to the connections a
participant opens, never to those it accepts (docs/security.md); the ``system_default``
section of OpenSSL's configuration, which OpenSSL applies to every TLS context it creates,
closes that gap. :func:`check_environment` refuses the settings that would reopen it.
"""
from dataclasses import dataclass
import datetime
from html import escape
import ipaddress
import os
from pathlib import Path
import re

from formation_control.ops import dds_profile
import yaml

FIXED_MEMBERS = ('plant', 'monitor', 'swarm', 'operator')
"""Members besides the vehicles: the swarm's own node, an operator's ``ros2`` tools."""
CLIENTS = ('operator',)
"""Members that listen on no port and connect to every other member: short-lived ``ros2``
commands come and go, and a listener's port is not always let in again at once
(docs/security.md). Two clients cannot reach each other."""
BASE_PORT = 7900
DAYS = 365
ROSTER = 'fleet.yaml'
PROFILE, OPENSSL_CONF, ENV = 'fastdds.xml', 'openssl.cnf', 'env.sh'
CERTS, CRL = 'fleet_certs.pem', 'crl.pem'
"""Every member's certificate (a signing fleet's roster, :mod:`formation_control.ops.signing`)
and the CA's revocation list, in each member's directory."""
MARKER = 'formation_control secure fleet'
VERIFY_REQUIRED = 'VerifyMode = Peer,Request,Require'
NAME = re.compile(r'(plant|monitor|swarm|operator|vehicle_[1-9]\d*)$')


class SecurityError(ValueError):
    """A fleet's security settings or environment that cannot be used, and why."""


@dataclass(frozen=True)
class Member:
    """One member of the fleet: its name, its address, its TLS port (None: it only connects)."""

    name: str
    address: str
    port: int = None


def members(num_vehicles):
    """Return the member names of a fleet of ``num_vehicles``: fixed members, then vehicles."""
    if not isinstance(num_vehicles, int) or num_vehicles < 1:
        raise SecurityError(f'num_vehicles {num_vehicles!r} is invalid: an integer >= 1')
    return list(FIXED_MEMBERS) + [f'vehicle_{k}' for k in range(1, num_vehicles + 1)]


def roster(num_vehicles, hosts=None, base_port=BASE_PORT, default_address='127.0.0.1'):
    """
    Return the fleet's members: each listens on the next port from ``base_port`` on.

    The plant, the monitor and the swarm's node take the first three, vehicle k
    ``base_port + 2 + k``; the :data:`CLIENTS` listen on no port.

    Parameters
    ----------
    num_vehicles : int
        The fleet's vehicles, ``vehicle_1..vehicle_N``.
    hosts : dict, optional
        {member name: IPv4 address}; the others are at ``default_address``.
    base_port : int
        The plant's TCP port; the others follow it, all in 1024..65535.
    default_address : str
        The address of the members ``hosts`` does not name.

    """
    names = members(num_vehicles)
    hosts = dict(hosts or {})
    unknown = sorted(set(hosts) - set(names))
    if unknown:
        raise SecurityError(f'--host {unknown[0]}: no such member; the members are '
                            f'{", ".join(FIXED_MEMBERS)} and vehicle_1..vehicle_{num_vehicles}')
    listeners = [name for name in names if name not in CLIENTS]
    last = 65536 - len(listeners)
    if not isinstance(base_port, int) or not 1024 <= base_port <= last:
        raise SecurityError(f'base_port {base_port!r} is invalid: an integer in 1024..{last} '
                            f'(one port per member but {", ".join(CLIENTS)} follows it)')
    out = []
    for name in names:
        address = hosts.get(name, default_address)
        try:
            ipaddress.IPv4Address(address)
        except ValueError:
            raise SecurityError(f'--host {name}={address}: not an IPv4 address') from None
        port = base_port + listeners.index(name) if name in listeners else None
        out.append(Member(name, address, port))
    return out


def parse_hosts(items):
    """Return {member: address} from ``NAME=ADDRESS`` strings (the CLI's ``--host``)."""
    hosts = {}
    for item in items:
        name, sep, address = item.partition('=')
        if not sep or not NAME.match(name):
            raise SecurityError(f'--host {item!r} is invalid: NAME=ADDRESS, NAME one of '
                                f'{", ".join(FIXED_MEMBERS)} or vehicle_K')
        hosts[name] = address
    return hosts


def _text(path):
    """Return ``path`` as XML element text (&, < and > escaped)."""
    return escape(str(path), quote=False)


def profile_xml(member, fleet, key=None, cert=None, ca=None):
    """
    Return the Fast DDS XML profile of ``member``: TCPv4 + TLS only, and its initial peers.

    Fast DDS 2.14 connects a pair of TCP participants from the one with the lower listening
    port, the other waiting for it (``TCPTransportInterface::OpenOutputChannel``); so a
    listening member lists the listeners on higher ports and is found by those on lower ones.
    Listing each other, two members race to connect and may never match (measured). A member
    with no port, or one not in ``fleet``, lists every listener.

    ``key`` and ``cert`` are its PEM files (none: it presents no certificate), ``ca`` the CA
    it trusts (none: it verifies nothing; only the tests' intruders go without). Nagle's
    algorithm is off: a lockstep step is a chain of small messages (3.3x faster, measured).
    Its writers heartbeat as every fleet's
    (:data:`~formation_control.ops.dds_profile.WRITER_SECTION`).
    """
    own = ''
    if key is not None:
        own = (f'<private_key_file>{_text(key)}</private_key_file>\n'
               f'        <cert_chain_file>{_text(cert)}</cert_chain_file>\n        ')
    trust = ('<verify_mode><verify>VERIFY_NONE</verify></verify_mode>' if ca is None else
             f'<verify_file>{_text(ca)}</verify_file>\n'
             '        <verify_mode><verify>VERIFY_PEER</verify></verify_mode>')
    member_of = member in fleet and member.port is not None
    peers = ''.join(f'\n          <locator><tcpv4><address>{m.address}</address>'
                    f'<physical_port>{m.port}</physical_port></tcpv4></locator>'
                    for m in fleet if m.port is not None
                    and (not member_of or m.port > member.port))
    listen = ('' if member.port is None else
              f'\n      <listening_ports><port>{member.port}</port></listening_ports>')
    builtin = (f'\n      <builtin>\n        <initialPeersList>{peers}\n        </initialPeersList>'
               f'\n      </builtin>' if peers else '')
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<!-- {MARKER}: {member.name}, written by formation-control secure -->
<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <transport_descriptors>
    <transport_descriptor>
      <transport_id>fleet_tls</transport_id>
      <type>TCPv4</type>{listen}
      <enable_tcp_nodelay>true</enable_tcp_nodelay>
      <tls>
        {own}{trust}
        <options><option>DEFAULT_WORKAROUNDS</option><option>SINGLE_DH_USE</option>
          <option>NO_SSLV2</option><option>NO_SSLV3</option><option>NO_TLSV1</option>
          <option>NO_TLSV1_1</option></options>
      </tls>
    </transport_descriptor>
  </transport_descriptors>
  <participant profile_name="{member.name}" is_default_profile="true">
    <rtps>
      <userTransports><transport_id>fleet_tls</transport_id></userTransports>
      <useBuiltinTransports>false</useBuiltinTransports>{builtin}
    </rtps>
  </participant>
{dds_profile.WRITER_SECTION}</profiles>
"""


def openssl_conf():
    """
    Return the OpenSSL configuration that makes every TLS context demand a valid peer cert.

    ``Require`` is a server's ``SSL_VERIFY_PEER | SSL_VERIFY_FAIL_IF_NO_PEER_CERT``: the
    listener refuses a client without a certificate or with one the fleet's CA did not sign.
    """
    return f"""# {MARKER}: written by formation-control secure
openssl_conf = openssl_init

[openssl_init]
ssl_conf = ssl_section

[ssl_section]
system_default = fleet_tls

[fleet_tls]
{VERIFY_REQUIRED}
MinProtocol = TLSv1.2
"""


def environment(directory, name, check=True):
    """
    Return the environment variables that make a process member ``name`` of the fleet.

    ``check``: the member's profile must exist in ``directory`` (False: the directory is where
    the fleet will be on its hosts).
    """
    home = Path(directory).absolute() / name
    if check and not (home / PROFILE).is_file():
        raise SecurityError(f'{home / PROFILE} does not exist: {name} is not a member of the '
                            f'fleet in {directory} (formation-control secure makes it)')
    return {'FASTRTPS_DEFAULT_PROFILES_FILE': str(home / PROFILE),
            'OPENSSL_CONF': str(home / OPENSSL_CONF),
            'ROS_AUTOMATIC_DISCOVERY_RANGE': 'SYSTEM_DEFAULT'}


UNSET = ('FASTDDS_DEFAULT_PROFILES_FILE', 'ROS_LOCALHOST_ONLY', 'ROS_STATIC_PEERS')


def member_env(directory, name, base):
    """Return ``base`` (a mapping) with the variables of member ``name``, the unsafe unset."""
    env = {k: v for k, v in base.items() if k not in UNSET}
    env.update(environment(directory, name))
    return env


def env_script(root, name):
    """Return the shell lines that make the current shell member ``name`` of the fleet at root."""
    lines = [f'export {k}={v}' for k, v in environment(root, name, check=False).items()]
    return '\n'.join([f'# {MARKER}: source this file to run as {name}',
                      f'unset {" ".join(UNSET)}', *lines]) + '\n'


def check_environment(env):
    """
    Return why ``env`` would open a fleet's TLS profile to anyone, or None.

    A profile with a ``<tls>`` transport is only a closed fleet when OpenSSL makes its listener
    demand a certificate (:func:`openssl_conf`) and rmw_fastrtps adds no transport of its own:
    ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` (or ``ROS_LOCALHOST_ONLY=1``) adds UDP and
    shared memory beside it, through which a local process with no certificate joins
    (measured, docs/security.md).
    """
    path = env.get('FASTRTPS_DEFAULT_PROFILES_FILE')
    if not path:
        return None
    try:
        text = Path(path).read_text()
    except OSError as err:
        return f'FASTRTPS_DEFAULT_PROFILES_FILE={path}: cannot be read ({err.strerror})'
    if '<tls>' not in text:
        return None
    if env.get('ROS_AUTOMATIC_DISCOVERY_RANGE') == 'LOCALHOST' or \
            env.get('ROS_LOCALHOST_ONLY') == '1':
        return ('ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (or ROS_LOCALHOST_ONLY=1) with the TLS '
                f'profile {path}: rmw_fastrtps then adds UDP and shared memory, which any '
                'local process joins without a certificate; use SYSTEM_DEFAULT (the profile '
                'lists the peers)')
    conf = env.get('OPENSSL_CONF')
    try:
        verified = conf is not None and VERIFY_REQUIRED in Path(conf).read_text()
    except OSError:
        verified = False
    if not verified:
        return (f'OPENSSL_CONF={conf}: with the TLS profile {path}, OPENSSL_CONF must name a '
                f'configuration with "{VERIFY_REQUIRED}" (the openssl.cnf that formation-control '
                'secure writes): without it the listener admits peers with no certificate')
    return None


def _name(common_name, organisation):
    from cryptography import x509
    from cryptography.x509.oid import NameOID
    return x509.Name([x509.NameAttribute(NameOID.ORGANIZATION_NAME, organisation),
                      x509.NameAttribute(NameOID.COMMON_NAME, common_name)])


def _key():
    from cryptography.hazmat.primitives.asymmetric import ec
    return ec.generate_private_key(ec.SECP256R1())


def _certificate(subject, public_key, issuer, issuer_key, days, ca):
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes
    from cryptography.x509.oid import ExtendedKeyUsageOID
    now = datetime.datetime.now(datetime.timezone.utc)
    builder = (x509.CertificateBuilder().subject_name(subject).issuer_name(issuer)
               .public_key(public_key).serial_number(x509.random_serial_number())
               .not_valid_before(now - datetime.timedelta(minutes=5))
               .not_valid_after(now + datetime.timedelta(days=days))
               .add_extension(x509.BasicConstraints(ca=ca, path_length=0 if ca else None),
                              critical=True)
               .add_extension(x509.KeyUsage(
                   digital_signature=True, content_commitment=False, key_encipherment=False,
                   data_encipherment=False, key_agreement=not ca, key_cert_sign=ca,
                   crl_sign=ca, encipher_only=False, decipher_only=False), critical=True))
    if not ca:
        builder = builder.add_extension(x509.ExtendedKeyUsage(
            [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]), critical=False)
    return builder.sign(issuer_key, hashes.SHA256())


def _write_private(path, key):
    from cryptography.hazmat.primitives import serialization
    data = key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                             serialization.NoEncryption())
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, 'wb') as out:
        out.write(data)


def _write_cert(path, cert):
    from cryptography.hazmat.primitives import serialization
    Path(path).write_bytes(cert.public_bytes(serialization.Encoding.PEM))


def load_ca(ca_dir):
    """Return the fleet CA's (certificate, key) in ``ca_dir``."""
    from cryptography import x509
    from cryptography.hazmat.primitives import serialization
    cert = x509.load_pem_x509_certificate((ca_dir / 'ca.pem').read_bytes())
    key = serialization.load_pem_private_key((ca_dir / 'ca.key').read_bytes(), None)
    return cert, key


def _write_roster_certs(directory, fleet, signing):
    """Write (or, not ``signing``, remove) each member's ``fleet_certs.pem``, copy ``crl.pem``."""
    bundle = b''.join((directory / m.name / 'cert.pem').read_bytes() for m in fleet)
    crl = directory / 'ca' / CRL
    for member in fleet:
        home = directory / member.name
        if not signing:
            (home / CERTS).unlink(missing_ok=True)
            continue
        (home / CERTS).write_bytes(bundle)
        if crl.is_file():
            (home / CRL).write_bytes(crl.read_bytes())


def make_ca(ca_dir, organisation, days=DAYS):
    """Make the fleet's CA in ``ca_dir`` (``ca.key``, mode 0600, and ``ca.pem``)."""
    ca_dir = Path(ca_dir)
    ca_dir.mkdir(parents=True, exist_ok=True)
    key = _key()
    subject = _name(f'{organisation} CA', organisation)
    cert = _certificate(subject, key.public_key(), subject, key, days, ca=True)
    _write_private(ca_dir / 'ca.key', key)
    _write_cert(ca_dir / 'ca.pem', cert)
    return cert, key


def write_fleet(directory, fleet, organisation='formation_control fleet', days=DAYS, root=None,
                signing=True):
    """
    Write the fleet's CA (kept if ``directory`` has one) and every member's files.

    ``directory/ca/`` holds the CA (its key belongs off the vehicles); ``directory/NAME/``
    the member's ``key.pem`` and ``cert.pem`` (kept if present, so that a member added later
    keeps the others' keys), ``ca.pem``, ``fastdds.xml``, ``openssl.cnf`` and ``env.sh``;
    ``directory/fleet.yaml`` the roster. The profiles and ``env.sh`` name their files under
    ``root``, the path of ``directory`` on the hosts (default: its own). ``signing``: each
    member's directory also gets the roster's certificates (``fleet_certs.pem``) and the CA's
    revocation list if any (``crl.pem``), and the members sign their control topics
    (:mod:`formation_control.ops.signing`); else ``fleet_certs.pem`` is removed. Returns the
    member directories.
    """
    if not isinstance(days, int) or days < 1:
        raise SecurityError(f'--days {days!r} is invalid: an integer >= 1')
    directory = Path(directory)
    root = Path(root).absolute() if root else directory.absolute()
    ca_dir = directory / 'ca'
    if (ca_dir / 'ca.key').exists():
        ca_cert, ca_key = load_ca(ca_dir)
    else:
        ca_cert, ca_key = make_ca(ca_dir, organisation, days)
    homes = []
    for member in fleet:
        home = directory / member.name
        home.mkdir(parents=True, exist_ok=True)
        if not (home / 'key.pem').exists():
            key = _key()
            cert = _certificate(_name(member.name, organisation), key.public_key(),
                                ca_cert.subject, ca_key, days, ca=False)
            _write_private(home / 'key.pem', key)
            _write_cert(home / 'cert.pem', cert)
        _write_cert(home / 'ca.pem', ca_cert)
        there = root / member.name
        (home / PROFILE).write_text(profile_xml(member, fleet, there / 'key.pem',
                                                there / 'cert.pem', there / 'ca.pem'))
        (home / OPENSSL_CONF).write_text(openssl_conf())
        (home / ENV).write_text(env_script(root, member.name))
        homes.append(home.absolute())
    _write_roster_certs(directory, fleet, signing)
    (directory / ROSTER).write_text(yaml.safe_dump(
        {'members': [{'name': m.name, 'address': m.address, 'port': m.port} for m in fleet]},
        sort_keys=False))
    return homes
