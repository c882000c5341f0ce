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
Several hosts on one machine, for the multi-host tests.

A network namespace per host, each joined by a veth pair to a bridge in a switch namespace.
The test subnet exists only inside the namespaces; deleting them (always, also when a test
fails) removes every link and address made here.
"""
import os
import re
import subprocess

SUBNET = '10.213.0'
PREFIX = 'fctest'


class HostsUnavailable(RuntimeError):
    pass


def ip(*args, ns=None):
    cmd = ['ip'] + (['-n', ns] if ns else []) + list(args)
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=30)
    if done.returncode:
        raise RuntimeError(f"{' '.join(cmd)}: {done.stderr.strip()}")
    return done.stdout


def _ours():
    try:
        listing = subprocess.run(['ip', 'netns', 'list'], capture_output=True, text=True,
                                 timeout=30).stdout
    except FileNotFoundError:
        return []
    return re.findall(rf'^({PREFIX}(\d+)\S*)', listing, re.M)


def sweep():
    """Delete namespaces left by test runs whose process no longer exists."""
    for name, pid in _ours():
        if not os.path.exists(f'/proc/{pid}'):
            subprocess.run(['ip', 'netns', 'del', name], capture_output=True, timeout=30)


class Hosts:
    """``n`` hosts ``h0..h{n-1}`` at ``10.213.0.1..n``; use as a context manager."""

    def __init__(self, n):
        tag = f'{PREFIX}{os.getpid()}'
        self.switch = f'{tag}sw'
        self.names = [f'{tag}h{i}' for i in range(n)]
        self.made = []

    def __enter__(self):
        sweep()
        try:
            self._add(self.switch)
        except (RuntimeError, FileNotFoundError) as err:
            raise HostsUnavailable(f'cannot create network namespaces here ({err}); the '
                                   f'multi-host tests need root (CAP_SYS_ADMIN, CAP_NET_ADMIN) '
                                   f'and iproute2') from err
        try:
            ip('link', 'add', 'br0', 'type', 'bridge', 'mcast_snooping', '0', ns=self.switch)
            ip('link', 'set', 'br0', 'up', ns=self.switch)
            for i, name in enumerate(self.names):
                self._add(name)
                ip('link', 'add', 'eth0', 'netns', name, 'type', 'veth', 'peer', 'name',
                   self.port(i), 'netns', self.switch)
                ip('link', 'set', self.port(i), 'master', 'br0', 'up', ns=self.switch)
                ip('addr', 'add', f'{self.address(i)}/24', 'dev', 'eth0', ns=name)
                ip('link', 'set', 'eth0', 'up', ns=name)
        except BaseException:
            self.__exit__()
            raise
        return self

    def _add(self, name):
        ip('netns', 'add', name)
        self.made.append(name)
        ip('link', 'set', 'lo', 'up', ns=name)

    def __exit__(self, *exc):
        for name in reversed(self.made):
            subprocess.run(['ip', 'netns', 'del', name], capture_output=True, timeout=30)
        self.made = []

    @staticmethod
    def port(i):
        return f'port{i}'

    @staticmethod
    def address(i):
        return f'{SUBNET}.{i + 1}'

    def prefix(self, i):
        """Return the command prefix that runs a program on host ``i``."""
        return ['ip', 'netns', 'exec', self.names[i]]

    def link(self, i, up):
        """Plug (``up``) or unplug host ``i``'s cable at the switch."""
        ip('link', 'set', self.port(i), 'up' if up else 'down', ns=self.switch)

    def multicast(self, enabled):
        """Make the switch forward the multicast packets DDS discovers with, or drop them."""
        for i in range(len(self.names)):
            done = subprocess.run(['bridge', '-n', self.switch, 'link', 'set', 'dev', self.port(i),
                                   'mcast_flood', 'on' if enabled else 'off'],
                                  capture_output=True, text=True, timeout=30)
            if done.returncode:
                raise RuntimeError(f'bridge link set mcast_flood: {done.stderr.strip()}')
