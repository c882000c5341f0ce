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

"""Signed control topics: who may sign which topic, the envelope, replays, revocation."""
import os

from formation_control.ops import security, signing
from formation_control.protocol.intake import MALFORMED, Rejection
import pytest

STATE = '/vehicle_3/formation_state'


@pytest.fixture(scope='module')
def fleet(tmp_path_factory):
    directory = tmp_path_factory.mktemp('fleet')
    security.write_fleet(directory, security.roster(3))
    return directory


def member(fleet, name):
    return signing.load_member(fleet / name)


def kind(got):
    assert isinstance(got, Rejection), got
    return got.kind


@pytest.mark.parametrize('topic, signer', [
    ('/vehicle_3/formation_state', 'vehicle_3'), ('/vehicle_12/cmd', 'vehicle_12'),
    ('/fleet_a/vehicle_2/cmd_vel', 'vehicle_2'), ('/vehicle_1/odom', 'plant'),
    ('/clock', 'plant'), ('/fleet_a/clock', 'plant'), ('/vehicle_1/flow', None),
    ('/formation/scenario', None), ('/vehicle_0/cmd', None), ('/xvehicle_1/cmd', None)])
def test_each_control_topic_has_one_signer(topic, signer):
    assert signing.signer_for(topic) == signer


def test_a_sealed_message_opens_to_its_payload_in_order(fleet):
    vehicle, plant = member(fleet, 'vehicle_3'), member(fleet, 'plant')
    payloads = [bytes([i]) * (10 + i) for i in range(5)]
    for payload in payloads:
        assert plant.verifier.unseal(STATE, vehicle.signer.seal(STATE, payload)) == payload


def test_the_envelope_is_a_uint8_multi_array(fleet):
    from rclpy.serialization import deserialize_message
    from std_msgs.msg import UInt8MultiArray
    data = member(fleet, 'vehicle_3').signer.seal(STATE, b'payload')
    msg = deserialize_message(data, UInt8MultiArray)
    assert bytes(msg.data).startswith(signing.MAGIC) and b'payload' in bytes(msg.data)
    assert signing.array_body(data) == bytes(msg.data)


def test_one_flipped_byte_anywhere_is_dropped(fleet):
    vehicle, plant = member(fleet, 'vehicle_3'), member(fleet, 'plant')
    data = vehicle.signer.seal(STATE, b'x' * 40)
    kinds = set()
    for i in range(signing.ARRAY_HEADER.size, len(data)):
        bad = bytearray(data)
        bad[i] ^= 0x01
        kinds.add(kind(plant.verifier.unseal(STATE, bytes(bad))))
    assert kinds <= {signing.BAD_SIGNATURE, signing.WRONG_SIGNER, signing.WRONG_TOPIC,
                     signing.UNSIGNED, MALFORMED}
    assert signing.BAD_SIGNATURE in kinds
    assert plant.verifier.unseal(STATE, data) == b'x' * 40


def test_another_member_cannot_sign_a_vehicles_topic(fleet):
    impostor, plant = member(fleet, 'vehicle_2'), member(fleet, 'plant')
    assert kind(plant.verifier.unseal(STATE, impostor.signer.seal(STATE, b'p'))) == \
        signing.WRONG_SIGNER
    forged = signing.Signer('vehicle_3', impostor.signer.sign)
    assert kind(plant.verifier.unseal(STATE, forged.seal(STATE, b'p'))) == signing.BAD_SIGNATURE


def test_a_signed_message_moved_to_another_topic_is_dropped(fleet):
    plant, vehicle = member(fleet, 'plant'), member(fleet, 'vehicle_2')
    data = plant.signer.seal('/vehicle_1/odom', b'odom')
    assert kind(vehicle.verifier.unseal('/vehicle_2/odom', data)) == signing.WRONG_TOPIC


def test_a_replayed_or_older_envelope_is_dropped(fleet):
    vehicle, plant = member(fleet, 'vehicle_3'), member(fleet, 'plant')
    first, second = (vehicle.signer.seal(STATE, b'a'), vehicle.signer.seal(STATE, b'b'))
    assert plant.verifier.unseal(STATE, first) == b'a'
    assert kind(plant.verifier.unseal(STATE, first)) == signing.REPLAY
    assert plant.verifier.unseal(STATE, second) == b'b'
    assert kind(plant.verifier.unseal(STATE, first)) == signing.REPLAY


def test_an_envelope_older_than_the_window_is_dropped_by_a_fresh_receiver(fleet):
    vehicle = member(fleet, 'vehicle_3')
    now = [10**18]
    old = signing.Signer('vehicle_3', vehicle.signer.sign, clock=lambda: now[0]).seal(STATE, b'o')
    now[0] += signing.WINDOW
    fresh = signing.Verifier(member(fleet, 'plant').verifier.verify, frozenset,
                             signing.ReplayWindow(clock=lambda: now[0]))
    assert kind(fresh.unseal(STATE, old)) == signing.REPLAY
    now[0] -= 1
    assert fresh.unseal(STATE, old) == b'o'


def test_a_signer_whose_clock_steps_back_keeps_its_sequence_increasing(fleet):
    now = [10**18]
    signer = signing.Signer('vehicle_3', member(fleet, 'vehicle_3').signer.sign,
                            clock=lambda: now[0])
    first = signing.parse(signer.seal(STATE, b'a'), STATE).sequence
    now[0] -= 10**9
    assert signing.parse(signer.seal(STATE, b'b'), STATE).sequence == first + 1


def test_a_restarted_signer_continues_above_its_last_sequence(fleet):
    plant = member(fleet, 'plant')
    before = member(fleet, 'vehicle_3').signer.seal(STATE, b'a')
    assert plant.verifier.unseal(STATE, before) == b'a'
    assert plant.verifier.unseal(STATE, member(fleet, 'vehicle_3').signer.seal(STATE, b'b')) \
        == b'b'


@pytest.mark.parametrize('data', [b'', b'\x00\x01\x00\x00', b'plain cdr bytes of a message',
                                  signing.array_message(b'no magic')])
def test_bytes_that_are_no_envelope_are_unsigned(fleet, data):
    assert kind(member(fleet, 'plant').verifier.unseal(STATE, data)) == signing.UNSIGNED


def test_a_truncated_envelope_is_malformed(fleet):
    data = member(fleet, 'vehicle_3').signer.seal(STATE, b'x' * 40)
    body = signing.array_body(data)
    for cut in (5, 9, 30, len(body) - 1):
        got = member(fleet, 'plant').verifier.unseal(STATE, signing.array_message(body[:cut]))
        assert kind(got) == MALFORMED


def test_a_certificate_of_another_ca_in_the_roster_is_refused(fleet, tmp_path):
    other = tmp_path / 'other'
    security.write_fleet(other, security.roster(1), organisation='another fleet')
    home = tmp_path / 'home'
    home.mkdir()
    for name in ('ca.pem', 'cert.pem', 'key.pem'):
        (home / name).write_bytes((fleet / 'vehicle_1' / name).read_bytes())
    (home / security.CERTS).write_bytes((fleet / 'plant/cert.pem').read_bytes()
                                        + (other / 'vehicle_1/cert.pem').read_bytes())
    with pytest.raises(security.SecurityError, match='not signed by the fleet CA'):
        signing.load_member(home)


def test_a_fleet_without_signing_has_no_roster_certificates(tmp_path):
    security.write_fleet(tmp_path, security.roster(1), signing=False)
    env = security.environment(tmp_path, 'vehicle_1')
    assert signing.member_home(env) is None and signing.check_member(env) is None
    security.write_fleet(tmp_path, security.roster(1))
    assert signing.member_home(env) == tmp_path.absolute() / 'vehicle_1'


def test_a_revoked_member_is_refused_and_its_envelopes_dropped_after_a_reload(tmp_path):
    security.write_fleet(tmp_path, security.roster(3))
    plant = member(tmp_path, 'plant')
    data = member(tmp_path, 'vehicle_2').signer.seal('/vehicle_2/cmd', b'c')
    assert signing.check_member(security.environment(tmp_path, 'vehicle_2')) is None
    assert signing.revoke(tmp_path, 'vehicle_2') == ['vehicle_2']
    refused = signing.check_member(security.environment(tmp_path, 'vehicle_2'))
    assert 'member vehicle_2 is revoked' in refused and '\n' not in refused
    assert signing.check_member(security.environment(tmp_path, 'vehicle_1')) is None
    assert plant.revocations() == frozenset()
    assert plant.revocations.refresh() and plant.revocations() == {'vehicle_2'}
    assert kind(plant.verifier.unseal('/vehicle_2/cmd', data)) == signing.REVOKED
    assert signing.revoke(tmp_path, 'vehicle_3') == ['vehicle_2', 'vehicle_3']
    security.write_fleet(tmp_path, security.roster(4))
    assert member(tmp_path, 'vehicle_4').revocations() == {'vehicle_2', 'vehicle_3'}


def test_a_revocation_list_not_signed_by_the_ca_is_refused(tmp_path):
    security.write_fleet(tmp_path / 'a', security.roster(1))
    security.write_fleet(tmp_path / 'b', security.roster(1))
    signing.revoke(tmp_path / 'b', 'vehicle_1')
    home = tmp_path / 'a' / 'plant'
    (home / security.CRL).write_bytes((tmp_path / 'b/plant' / security.CRL).read_bytes())
    refused = signing.check_member(security.environment(tmp_path / 'a', 'plant'))
    assert 'not signed by the fleet CA' in refused


def test_revoking_a_stranger_names_it(tmp_path):
    security.write_fleet(tmp_path, security.roster(1))
    with pytest.raises(security.SecurityError, match='vehicle_7 is not a member'):
        signing.revoke(tmp_path, 'vehicle_7')
    assert not os.path.exists(tmp_path / 'ca' / security.CRL)
