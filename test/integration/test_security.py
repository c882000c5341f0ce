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

"""The TLS fleet's files and rules (formation_control.ops.security): no ROS graph."""
import os
import re
import socket
import ssl
import stat
import subprocess
import threading
import xml.etree.ElementTree as ET

from cryptography import x509
from cryptography.hazmat.primitives.asymmetric import ec
from formation_control.cli import main
from formation_control.ops import security
import pytest
from rosutil import BIN

NS = {'f': 'http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles'}


def peers(xml):
    root = ET.fromstring(xml)
    return [(loc.find('f:address', NS).text, int(loc.find('f:physical_port', NS).text))
            for loc in root.iterfind('.//f:initialPeersList/f:locator/f:tcpv4', NS)]


def test_the_roster_gives_each_member_its_own_port_and_address():
    fleet = security.roster(3, {'plant': '10.0.0.1', 'vehicle_2': '10.0.0.3'}, base_port=8000)
    assert [(m.name, m.address, m.port) for m in fleet] == [
        ('plant', '10.0.0.1', 8000), ('monitor', '127.0.0.1', 8001),
        ('swarm', '127.0.0.1', 8002), ('operator', '127.0.0.1', None),
        ('vehicle_1', '127.0.0.1', 8003), ('vehicle_2', '10.0.0.3', 8004),
        ('vehicle_3', '127.0.0.1', 8005)]


@pytest.mark.parametrize('args, message', [
    ((0,), 'num_vehicles 0 is invalid: an integer >= 1'),
    ((2, {'vehicle_3': '10.0.0.1'}), '--host vehicle_3: no such member; the members are plant, '
                                     'monitor, swarm, operator and vehicle_1..vehicle_2'),
    ((2, {'plant': '10.0.0'}), '--host plant=10.0.0: not an IPv4 address'),
    ((2, None, 80), 'base_port 80 is invalid: an integer in 1024..65531'),
    ((2, None, 65532), 'base_port 65532 is invalid'),
])
def test_a_bad_roster_is_refused_naming_the_setting(args, message):
    with pytest.raises(security.SecurityError, match=message.replace('.', r'\.')):
        security.roster(*args)


@pytest.mark.parametrize('item', ['plant', 'boat_1=10.0.0.1', 'vehicle_0=10.0.0.1'])
def test_a_host_assignment_needs_a_member_and_an_address(item):
    with pytest.raises(security.SecurityError, match=rf"--host '{item}' is invalid: "
                                                     r'NAME=ADDRESS'):
        security.parse_hosts([item])


def test_each_pair_of_listeners_is_connected_once_from_the_lower_port():
    fleet = security.roster(3, base_port=8000)
    lists = {m.name: peers(security.profile_xml(m, fleet)) for m in fleet}
    local = [('127.0.0.1', p) for p in range(8000, 8006)]
    assert lists['plant'] == local[1:]
    assert lists['vehicle_2'] == local[5:]
    assert lists['vehicle_3'] == []
    listeners = [m for m in fleet if m.port is not None]
    pairs = {frozenset((m.name, n.name)) for m in listeners for n in listeners
             if ('127.0.0.1', n.port) in lists[m.name]}
    assert len(pairs) == len(listeners) * (len(listeners) - 1) // 2
    for name in security.CLIENTS:
        assert lists[name] == local
    stranger = security.Member('stranger', '127.0.0.1', 9000)
    assert peers(security.profile_xml(stranger, fleet)) == local


def test_a_client_member_listens_on_no_port():
    fleet = security.roster(1)
    root = ET.fromstring(security.profile_xml(fleet[3], fleet, 'k.pem', 'c.pem', 'ca.pem'))
    assert fleet[3].name == 'operator'
    assert root.find('.//f:listening_ports', NS) is None


def test_a_profile_has_tls_over_tcp_as_its_only_transport():
    fleet = security.roster(1)
    vehicle = fleet[-1]
    root = ET.fromstring(security.profile_xml(vehicle, fleet, 'k.pem', 'c.pem', 'ca.pem'))
    rtps = root.find('f:participant/f:rtps', NS)
    assert rtps.find('f:useBuiltinTransports', NS).text == 'false'
    assert [t.text for t in rtps.iterfind('f:userTransports/f:transport_id', NS)] == ['fleet_tls']
    tcp = root.find('f:transport_descriptors/f:transport_descriptor', NS)
    assert tcp.find('f:type', NS).text == 'TCPv4'
    assert tcp.find('f:listening_ports/f:port', NS).text == str(vehicle.port)
    assert tcp.find('f:enable_tcp_nodelay', NS).text == 'true'
    tls = tcp.find('f:tls', NS)
    files = ('private_key_file', 'cert_chain_file', 'verify_file')
    assert [tls.find(f'f:{k}', NS).text for k in files] == ['k.pem', 'c.pem', 'ca.pem']
    assert tls.find('f:verify_mode/f:verify', NS).text == 'VERIFY_PEER'


def test_the_fleet_s_certificates_chain_to_its_ca_and_keys_stay_private(tmp_path):
    fleet = security.roster(2)
    homes = security.write_fleet(tmp_path / 'fleet', fleet, organisation='test fleet')
    assert [h.name for h in homes] == [m.name for m in fleet]
    ca = x509.load_pem_x509_certificate((tmp_path / 'fleet/ca/ca.pem').read_bytes())
    assert ca.extensions.get_extension_for_class(x509.BasicConstraints).value.ca
    for home in homes:
        cert = x509.load_pem_x509_certificate((home / 'cert.pem').read_bytes())
        cert.verify_directly_issued_by(ca)
        assert cert.subject.rfc4514_string() == f'CN={home.name},O=test fleet'
        assert not cert.extensions.get_extension_for_class(x509.BasicConstraints).value.ca
        assert isinstance(cert.public_key(), ec.EllipticCurvePublicKey)
        assert stat.S_IMODE(os.stat(home / 'key.pem').st_mode) == 0o600
        assert not (home / 'ca.key').exists()
    assert stat.S_IMODE(os.stat(tmp_path / 'fleet/ca/ca.key').st_mode) == 0o600
    other = security.write_fleet(tmp_path / 'other', fleet)
    stranger = x509.load_pem_x509_certificate((other[0] / 'cert.pem').read_bytes())
    with pytest.raises(ValueError):
        stranger.verify_directly_issued_by(ca)


def handshake(server, client, client_ca):
    """
    Return the errors of a mutual TLS handshake, or None.

    ``server`` is a member directory; the client presents the certificate of directory
    ``client`` (None: none) and trusts ``client_ca``.
    """
    def context(home, side, ca):
        ctx = ssl.SSLContext(side)
        if home is not None:
            ctx.load_cert_chain(home / 'cert.pem', home / 'key.pem')
        ctx.load_verify_locations(ca)
        ctx.verify_mode = ssl.CERT_REQUIRED
        ctx.check_hostname = False
        return ctx
    a, b = socket.socketpair()
    errors = []

    def serve():
        try:
            with context(server, ssl.PROTOCOL_TLS_SERVER, server / 'ca.pem').wrap_socket(
                    a, server_side=True):
                pass
        except (ssl.SSLError, OSError) as err:
            errors.append(f'server: {err}')
    thread = threading.Thread(target=serve)
    thread.start()
    try:
        with context(client, ssl.PROTOCOL_TLS_CLIENT, client_ca).wrap_socket(b) as tls:
            tls.recv(1)
    except (ssl.SSLError, OSError) as err:
        errors.append(f'client: {err}')
    finally:
        b.close()
        thread.join(10)
    return errors or None


def test_members_pass_a_mutual_tls_handshake_and_a_stranger_fails_it(tmp_path):
    """Check what TLS runs in OpenSSL: the chain, the key usages, client and server purposes."""
    fleet = security.roster(1)
    security.write_fleet(tmp_path / 'a', fleet)
    security.write_fleet(tmp_path / 'b', fleet)
    plant, ca = tmp_path / 'a/plant', tmp_path / 'a/ca/ca.pem'
    assert handshake(plant, tmp_path / 'a/vehicle_1', ca) is None
    for client in (tmp_path / 'b/vehicle_1', None):
        refused = [e for e in handshake(plant, client, ca) or [] if e.startswith('server: ')]
        assert refused and re.search('certificate verify failed|peer did not return a '
                                     'certificate', refused[0]), refused


def test_writing_again_keeps_the_ca_and_the_keys_and_adds_members(tmp_path):
    security.write_fleet(tmp_path, security.roster(2))
    before = {p: p.read_bytes() for p in tmp_path.glob('*/*.pem') if p.name != security.CERTS}
    security.write_fleet(tmp_path, security.roster(3, {'vehicle_3': '10.1.1.3'}))
    assert all(p.read_bytes() == data for p, data in before.items())
    assert (tmp_path / 'vehicle_3/key.pem').exists()
    roster = (tmp_path / 'plant' / security.CERTS).read_bytes()    # the roster has grown
    assert all((tmp_path / m / 'cert.pem').read_bytes() in roster
               for m in security.members(3))
    assert peers((tmp_path / 'vehicle_3/fastdds.xml').read_text()) == []
    assert peers((tmp_path / 'plant/fastdds.xml').read_text())[-1] == (
        '10.1.1.3', security.BASE_PORT + 5)
    ca = x509.load_pem_x509_certificate((tmp_path / 'ca/ca.pem').read_bytes())
    x509.load_pem_x509_certificate((tmp_path / 'vehicle_3/cert.pem').read_bytes()) \
        .verify_directly_issued_by(ca)
    assert '10.1.1.3' in (tmp_path / 'fleet.yaml').read_text()


def test_the_files_name_the_fleet_s_path_on_its_hosts(tmp_path):
    security.write_fleet(tmp_path / 'here', security.roster(1), root='/etc/fleet')
    xml = (tmp_path / 'here/vehicle_1/fastdds.xml').read_text()
    assert '<private_key_file>/etc/fleet/vehicle_1/key.pem</private_key_file>' in xml
    env = (tmp_path / 'here/vehicle_1/env.sh').read_text()
    assert 'export FASTRTPS_DEFAULT_PROFILES_FILE=/etc/fleet/vehicle_1/fastdds.xml' in env
    assert 'export OPENSSL_CONF=/etc/fleet/vehicle_1/openssl.cnf' in env
    assert 'export ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT' in env


def member(tmp_path, name='vehicle_1'):
    security.write_fleet(tmp_path, security.roster(1))
    return security.environment(tmp_path, name)


def test_a_member_s_environment_passes_the_check(tmp_path):
    assert security.check_environment(member(tmp_path)) is None
    assert security.check_environment({'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}) is None


@pytest.mark.parametrize('change, message', [
    ({'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'},
     'ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST .* any local process joins without a certificate'),
    ({'ROS_LOCALHOST_ONLY': '1'}, 'ROS_LOCALHOST_ONLY=1'),
    ({'OPENSSL_CONF': None}, 'OPENSSL_CONF=None: .* admits peers with no certificate'),
    ({'OPENSSL_CONF': '/etc/ssl/openssl.cnf'}, 'OPENSSL_CONF=/etc/ssl/openssl.cnf: .* must name'),
    ({'FASTRTPS_DEFAULT_PROFILES_FILE': '/nonexistent.xml'},
     r'FASTRTPS_DEFAULT_PROFILES_FILE=/nonexistent.xml: cannot be read \(No such file'),
])
def test_an_environment_that_opens_the_fleet_is_refused(tmp_path, change, message):
    env = member(tmp_path)
    env.update(change)
    env = {k: v for k, v in env.items() if v is not None}
    assert re.search(message, security.check_environment(env) or '')


def test_a_node_started_with_the_profile_and_localhost_exits_2_with_the_reason(tmp_path):
    env = dict(os.environ, **member(tmp_path))
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    done = subprocess.run([str(BIN / 'vehicle'), '--ros-args', '-p', 'vehicle_id:=1'], env=env,
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert 'error: ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (or ROS_LOCALHOST_ONLY=1) with the ' \
           'TLS profile' in done.stderr


def test_an_unknown_member_has_no_environment(tmp_path):
    security.write_fleet(tmp_path, security.roster(1))
    with pytest.raises(security.SecurityError, match='vehicle_2 is not a member of the fleet'):
        security.environment(tmp_path, 'vehicle_2')


def test_the_secure_command_writes_the_fleet_and_lists_its_members(tmp_path, capsys):
    assert main(['secure', str(tmp_path / 'f'), '--vehicles', '2', '--host',
                 'vehicle_2=10.0.0.2', '--base-port', '8100']) == 0
    out = capsys.readouterr().out
    assert 'vehicle_2    10.0.0.2:8104' in out and 'keep ca.key off the fleet' in out
    assert 'operator     127.0.0.1 (connects only)' in out
    assert sorted(p.name for p in (tmp_path / 'f').iterdir()) == sorted(
        ['ca', 'fleet.yaml', *security.members(2)])
    assert main(['secure', str(tmp_path / 'g'), '--vehicles', '2', '--host', 'boat=1']) == 2
    assert "--host 'boat=1' is invalid" in capsys.readouterr().err
