import os
from pathlib import Path
from types import SimpleNamespace

import pytest

CONFIG = Path(__file__).resolve().parents[1] / 'config'


@pytest.fixture
def config_dir():
    return CONFIG


os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'


@pytest.fixture
def ros(monkeypatch):
    """A private ROS_DOMAIN_ID, the processes the test starts, and a probe node."""
    from rosutil import domains, Probe, Processes, ros_environment, shm_clean
    with domains() as (did,):
        env = ros_environment(did)
        monkeypatch.setenv('ROS_DOMAIN_ID', str(did))
        procs = Processes(env)
        probe = Probe(did)
        try:
            yield SimpleNamespace(domain_id=did, env=env, procs=procs, probe=probe)
        finally:
            probe.close()
            procs.stop_all()
            shm_clean(env)


@pytest.fixture
def nodes():
    """
    In-process nodes on a private ROS_DOMAIN_ID: ``nodes.plant(...)``, ``nodes.vehicle(k,
    ...)``, ``nodes.monitor(...)`` with the probe's ``collect`` and ``spin_until``; every node is
    destroyed and the context shut down at teardown.
    """
    from rosutil import domains, Nodes
    with domains() as (did,):
        made = Nodes(did)
        try:
            yield made
        finally:
            made.close()
